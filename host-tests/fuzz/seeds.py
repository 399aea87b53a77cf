#!/usr/bin/env python3
"""Writes seed inputs for the fuzz targets into corpus/<target>/, from the
test vectors (host-tests/vectors): one file per seed, named by its hash, so
running it again changes nothing. The vectors, not these files, are kept in
git."""
import hashlib
import os
import re
import struct
import sys
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
VECTORS = os.path.join(HERE, "..", "vectors")
LINE = re.compile(r"^(req|ok|fail|errorcmd) \w+ \|(.*)$")


def put(target, data):
    d = os.path.join(HERE, "corpus", target)
    os.makedirs(d, exist_ok=True)
    name = hashlib.sha1(data).hexdigest()
    path = os.path.join(d, name)
    if not os.path.exists(path):
        with open(path, "wb") as f:
            f.write(data)


def packet(payload):
    # DataSheet header (chapter 5.2, NOTES.md): "LTBR", total = 12 + payload, payload length.
    return b"LTBR" + struct.pack("<II", 12 + len(payload), len(payload)) + payload


def main():
    blocks = {}
    # The top level and the V6 and V5-only corpora (the fuzz targets build
    # the codec with `v6`; the V5-only lines are good seeds all the same).
    files = []
    for sub in ("", "v6", "v5-only"):
        d = os.path.join(VECTORS, sub)
        files += [os.path.join(sub, n) for n in sorted(os.listdir(d)) if n.endswith(".txt")]
    for name in files:
        block = None
        with open(os.path.join(VECTORS, name), encoding="utf-8") as f:
            for line in f:
                line = line.rstrip("\n")
                if line.startswith("@ "):
                    block = (name, line)
                    continue
                m = LINE.match(line)
                if not m:
                    continue
                text = m.group(2).encode("utf-8")
                put("request", text)
                put("reply", b"\x02" + text)
                blocks.setdefault(block, []).append(text)
    # The framer sees whole exchanges: a block's messages back to back,
    # with and without line ends, behind a seed byte for the read sizes.
    for i, msgs in enumerate(blocks.values()):
        put("framer", bytes([i % 256]) + b"".join(msgs))
        put("framer", bytes([(i * 7) % 256]) + b"\r\n".join(msgs) + b"\r\n")
    sheets = os.path.join(VECTORS, "datasheet")
    payloads = []
    if os.path.isdir(sheets):
        for name in sorted(os.listdir(sheets)):
            if name.endswith(".json"):
                with open(os.path.join(sheets, name), "rb") as f:
                    payloads.append(f.read())
    if not payloads:
        payloads.append(b'{"StateAndError":{"robotState":33,"robotMoving":0}}')
    for i, p in enumerate(payloads):
        put("datasheet", bytes([i]) + packet(p))
        # Two packets with garbage and a false magic between them.
        put("datasheet", bytes([i + 100]) + packet(p) + b"\x00LTB\xffLTBR\x01\x00" + packet(p))
    gateway_seeds()
    enip_seeds()
    return 0


def mbap(tid, pdu):
    return struct.pack(">HHHB", tid, 0, len(pdu) + 1, 1) + pdu


def fc16(addr, words):
    return struct.pack(">BHHB", 16, addr, len(words), 2 * len(words)) + b"".join(struct.pack(">H", w) for w in words)


def text(t, regs):
    b = t.encode() + b"\0" * (2 * regs)
    return [(b[2 * i] << 8) | b[2 * i + 1] for i in range(regs)]


def gateway_seeds():
    """Seeds of the gateway's targets: a PLC's frames, robot replies, images."""
    one = 0x3F80  # 1.0f, high word
    frames = [
        mbap(1, struct.pack(">BHH", 3, 0, 50)),                       # read the status block
        mbap(2, fc16(200, [0, 13, 7, 0, 0, 0, one, 0])),              # code 13, P0 0, P1 1
        mbap(3, struct.pack(">BHH", 6, 200, 1)),                      # Execute
        mbap(4, fc16(602, text("MoveRelJ,0,1,1,5,;", 10))),           # a RAW request
        mbap(5, struct.pack(">BHH", 5, 9600, 0xFF00)),                # RAW Execute by coil
        mbap(6, fc16(1200, text("GrpStop,0,;", 6)) ),                 # a trigger entry
        mbap(7, fc16(1100, [1])),                                     # its bit
        mbap(8, fc16(105, [50])),                                     # CFG_POLL_MS
        mbap(9, fc16(140, [1, 1])),                                   # heartbeat, apply
        mbap(10, struct.pack(">BHHHHB", 23, 0, 10, 140, 1, 2) + struct.pack(">H", 2)),
    ]
    put("gateway_modbus", bytes([5]) + b"".join(frames))
    put("gateway_modbus", bytes([200]) + b"".join(frames[:3]) + b"\x00\x01\x12\x34\x00\x06\x01\x03\x00\x00\x00\x01")
    replies = [b"MoveRelJ,OK,;", b"ReadRobotState,OK,0,1,0,0,0,1,0,0,0,1,1,1,1,;", b"ReadCurFSM,OK,33,;",
               b"SetBoxDO,Fail,20018,;", b"errorcmd,;", b"\x01\xff;", b"GrpStop,OK,;"]
    put("gateway_robot", b"".join(bytes([0x80 | len(r)]) + r for r in replies))
    # A valid image: the default configuration, one trigger entry.
    cfg = [0, 0, 10003, 0, 10003, 100, 1000, 0, 0, 1, 0, 200, 0, 0, 10005, 0]
    trig = []
    for n in range(16):
        trig += text("GrpStop,0,;" if n == 3 else "", 96)
    body = b"HGW1" + struct.pack("<HH", 1, len(cfg) + len(trig)) + b"".join(struct.pack("<H", w) for w in cfg + trig)
    image = body + struct.pack("<I", zlib.crc32(body) & 0xFFFFFFFF)
    put("gateway_image", image)
    put("gateway_image", image[:-1] + bytes([image[-1] ^ 1]))
    # Format 2 (written by register map 1.2): settings as (register, value) pairs, the
    # triggers, the password (none: 52 zero bytes), the CRC. One with no
    # settings (all defaults), one with a poll period and a heartbeat.
    tbytes = b"".join(struct.pack("<H", w) for w in trig)
    for pairs in ([], [(105, 50), (140, 1)]):
        body = b"HGW1" + struct.pack("<HH", 2, len(pairs)) + b"".join(struct.pack("<HH", a, v) for a, v in pairs)
        body += tbytes + bytes(52)
        put("gateway_image", body + struct.pack("<I", zlib.crc32(body) & 0xFFFFFFFF))
    # Format 3 (written since the settings schema): settings as (id, length,
    # value) by their stable ids: the poll period (id 8, 50 ms), listen mode
    # (id 4), the MQTT broker's name (id 27), an id no version knows (999).
    for entries in ([], [(8, struct.pack("<H", 50)), (4, b"\x01"), (27, b"broker.plant"), (999, b"xyz")]):
        settings = b"".join(struct.pack("<HB", i, len(v)) + v for i, v in entries)
        body = b"HGW1" + struct.pack("<HH", 3, len(settings)) + settings + tbytes + bytes(52)
        put("gateway_image", body + struct.pack("<I", zlib.crc32(body) & 0xFFFFFFFF))
    # Format 4 (written since accounts): format 3's settings and triggers,
    # then the accounts: a count, and each its name's length, the name
    # (16, zero-padded), the role (3 admin, 1 viewer) and its password
    # (PBKDF2 rounds, salt, hash).
    def account(name, role):
        return bytes([len(name)]) + name.ljust(16, b"\0") + bytes([role]) \
            + struct.pack("<I", 10) + bytes(range(16)) + bytes(range(32, 64))
    for accounts in ([], [account(b"admin", 3), account(b"night-shift", 1)]):
        settings = struct.pack("<HB", 8, 2) + struct.pack("<H", 50)
        body = b"HGW1" + struct.pack("<HH", 4, len(settings)) + settings + tbytes \
            + bytes([len(accounts)]) + b"".join(accounts)
        put("gateway_image", body + struct.pack("<I", zlib.crc32(body) & 0xFFFFFFFF))
    # Web requests: reads, the first password, a configuration post, a login.
    # Named by the device's address; changes come from its own page (Origin)
    # with the JSON content type, so that the seeds get past those checks.
    def http(method, path, body=b"", headers=()):
        head = f"{method} {path} HTTP/1.1\r\nHost: 10.0.0.1\r\n"
        if method == "POST":
            head += "Origin: http://10.0.0.1\r\nContent-Type: application/json\r\n"
        head += "".join(f"{h}\r\n" for h in headers)
        return head.encode() + f"Content-Length: {len(body)}\r\n\r\n".encode() + body
    put("gateway_http", bytes([9]) + http("GET", "/api/status") + http("GET", "/api/log"))
    put("gateway_http", bytes([64]) + http("GET", "/"))
    # The first administrator with the test world's setup code, then what
    # an administrator does; a login with a wrong password; account changes.
    setup = b'{"code":"ABCD-EFGH-JKMN","name":"admin","password":"correct horse"}'
    put("gateway_http", bytes([17]) + http("POST", "/api/setup", setup)
        + http("POST", "/api/config", b'{"settings":{"link.poll_ms":"50"},"triggers":["GrpStop,0,;"]}',
               ["Cookie: hgw_session=00112233445566778899aabbccddeeff"]))
    put("gateway_http", bytes([33]) + http("POST", "/api/setup", setup)
        + http("POST", "/api/login", b'{"name":"admin","password":"wrong password"}')
        + http("POST", "/api/login", b'{"name":"admin","password":"correct horse"}')
        + http("POST", "/api/trigger/3", b"SetBoxDO,1,1,;", ["Authorization: Bearer 00"]))
    put("gateway_http", bytes([41]) + http("POST", "/api/setup", b'{"code":"abcd efgh jkmn","name":"root","password":"a \\"quoted\\" one"}')
        + http("POST", "/api/accounts", b'{"op":"add","name":"view","role":"viewer","password":"long enough pw"}')
        + http("POST", "/api/accounts", b'{"op":"role","name":"view","role":"admin"}')
        + http("POST", "/api/accounts", b'{"op":"remove","name":"root"}')
        + http("GET", "/api/accounts") + http("GET", "/api/audit?format=csv")
        + http("POST", "/api/password", b'{"current":"x","password":"\\u0041\\u0042cdefghijk"}'))
    http_rule_seeds()
    mqtt_seeds()


def http_rule_seeds():
    """Web requests at the edges of the rules the server checks before any
    route (web/mod.rs: `framing`, `own_host`, `same_origin`, `json_type`)
    and of its connection limits: each seed is one connection, requests
    kept alive back to back, so that one input crosses several rules."""
    def req(method, path, headers, body=b""):
        head = f"{method} {path} HTTP/1.1\r\n" + "".join(f"{h}\r\n" for h in headers)
        return head.encode() + b"\r\n" + body

    def post(path, body, headers=("Host: 10.0.0.1", "Origin: http://10.0.0.1",
                                  "Content-Type: application/json")):
        return req("POST", path, list(headers) + [f"Content-Length: {len(body)}"], body)

    host = "Host: 10.0.0.1"
    # Host: none, two, a port, a bad port, names the device does not
    # answer to, loopback names from a client that is not on loopback.
    hosts = [
        req("GET", "/api/session", []),
        req("GET", "/api/session", [host, host]),
        req("GET", "/api/session", ["Host: 10.0.0.1:8080"]),
        req("GET", "/api/session", ["Host: 10.0.0.1:65536"]),
        req("GET", "/api/session", ["Host: 10.0.0.1:+80"]),
        req("GET", "/api/session", ["Host: 10.0.0.1:"]),
        req("GET", "/api/session", ["Host: :80"]),
        req("GET", "/api/session", ["Host: evil.example"]),
        req("GET", "/api/session", ["Host: 10.0.0.1.evil.example"]),
        req("GET", "/api/session", ["Host: localhost:80"]),
        req("GET", "/api/session", ["Host: [::1]:80"]),
        req("HEAD", "/api/status", [host]),
    ]
    put("gateway_http", bytes([3]) + b"".join(hosts))
    # A change: Origin of another site, https, none (Sec-Fetch-Site instead),
    # content types, then one that passes.
    changes = [
        post("/api/logout", b"", (host, "Origin: http://evil.example", "Content-Type: application/json")),
        post("/api/logout", b"", (host, "Origin: https://10.0.0.1", "Content-Type: application/json")),
        post("/api/logout", b"", (host, "Origin: http://10.0.0.1:8080", "Content-Type: application/json")),
        post("/api/logout", b"", (host, "Origin: null", "Content-Type: application/json")),
        post("/api/logout", b"", (host, "Sec-Fetch-Site: same-origin", "Content-Type: application/json")),
        post("/api/logout", b"", (host, "Sec-Fetch-Site: cross-site", "Content-Type: application/json")),
        post("/api/logout", b"", (host, "Origin: http://10.0.0.1", "Content-Type: text/plain")),
        post("/api/logout", b"", (host, "Origin: http://10.0.0.1", "Content-Type: application/json; charset=utf-8")),
        post("/api/logout", b"", (host, "Origin: http://10.0.0.1", "Content-Type: APPLICATION/JSON")),
        post("/api/logout", b"", (host, "Origin: http://10.0.0.1")),
        post("/api/login", b"correct horse"),
    ]
    put("gateway_http", bytes([11]) + b"".join(changes))
    # Framing: Content-Length twice (equal, different), a list, a sign,
    # empty, too long; Transfer-Encoding chunked (with a request smuggled
    # in its body) and others. Each closes the connection: one per seed.
    hidden = b"GET /api/config HTTP/1.1\r\nHost: 10.0.0.1\r\n\r\n"
    framing = [
        ["Content-Length: 4", "Content-Length: 4"],
        ["Content-Length: 4", "Content-Length: 5"],
        ["Content-Length: 4, 4"],
        ["Content-Length: +4"],
        ["Content-Length: "],
        ["Content-Length: 1234567890"],
        ["Transfer-Encoding: chunked"],
        ["Transfer-Encoding: gzip, chunked"],
        ["Transfer-Encoding: chunked", "Content-Length: 4"],
        ["Transfer-Encoding:  CHUNKED"],
    ]
    for i, extra in enumerate(framing):
        body = b"4\r\nnull\r\n0\r\n\r\n" if any("Transfer" in h for h in extra) else b"null"
        put("gateway_http", bytes([20 + i])
            + req("POST", "/api/logout", [host, "Origin: http://10.0.0.1", "Content-Type: application/json"] + extra, body)
            + hidden)
    # Keep-alive to its end: 101 requests on one connection (the 100th
    # answer closes it), and a request after `Connection: close`.
    small = req("GET", "/api/session", [host])
    put("gateway_http", bytes([64]) + small * 101)
    put("gateway_http", bytes([5]) + small + req("GET", "/api/session", [host, "Connection: close"]) + small)


def mqtt_seeds():
    """Seeds of gateway_mqtt (its input format: fuzz_targets/gateway_mqtt.rs):
    a setup byte, then operations, each a byte (low nibble the operation,
    high nibble a delay after it) and its arguments. The broker's session:
    CONNACK 0, SUBACK, an NCMD rebirth (the one write the node obeys),
    PINGRESP; the same as raw bytes; commands of every QoS and topic;
    refusals, timeouts and reconnects; packets too long for the client; a
    primary host's STATE."""
    def mqtt_str(b):
        return struct.pack(">H", len(b)) + b

    def packet(first, body):
        rem, n = b"", len(body)
        while True:
            d, n = n % 128, n // 128
            rem += bytes([d | (0x80 if n else 0)])
            if not n:
                break
        return bytes([first]) + rem + body

    def field(num, wire, value):
        def varint(v):
            out = b""
            while True:
                d, v = v & 0x7F, v >> 7
                out += bytes([d | (0x80 if v else 0)])
                if not v:
                    return out
        key = varint(num << 3 | wire)
        return key + (varint(value) if wire == 0 else varint(len(value)) + value)

    def metric(name, datatype, value_field, value):
        return field(1, 2, name) + field(4, 0, datatype) + field(value_field, 0, value)

    # Sparkplug B payloads: metrics (field 2), each a name, a datatype, a value.
    rebirth = field(2, 2, metric(b"Node Control/Rebirth", 11, 14, 1))
    reboot = field(2, 2, metric(b"Node Control/Reboot", 11, 14, 1))
    move = field(1, 0, 1700000000000) + field(2, 2, metric(b"robot/J1", 9, 10, 5))
    ncmd = b"spBv1.0/G/NCMD/E"
    connack, suback, pingresp = bytes([0x20, 2, 0, 0]), bytes([0x90, 3, 0, 1, 0]), bytes([0xD0, 0])
    pub_rebirth = packet(0x30, mqtt_str(ncmd) + rebirth)

    # Operations.
    def raw(b):
        return bytes([0x00, len(b)]) + b
    def conn_ack(code=0):
        return bytes([0x01, code])
    sub_ack = bytes([0x02, 0x05, 0x00])           # id 1, one code: 0
    def publish(flags, payload=b"", pid=None, built=None):
        out = bytes([0x03, flags])
        if flags & 3:
            out += struct.pack(">H", pid or 1)
        if flags & 0x80:
            return out + built
        return out + bytes([len(payload)]) + payload
    ping_resp = bytes([0x04])
    def wait(code):                               # ((code & 63) + 1) x 10 ms / 100 ms / 1 s / 10 s
        return bytes([0x06, code])
    close, reset, listen, blackhole = b"\x07", b"\x08", b"\x09", b"\x0a"
    def robot(kind, arg):
        return bytes([0x0B, kind, arg])
    def oversized(kind, arg=b""):
        return bytes([0x05, kind]) + arg

    ka30_up, ka1_up, ka4_bytewise = 0x13, 0x10, 0x31
    # The valid session: CONNACK, SUBACK, an NCMD rebirth, a ping, time.
    put("gateway_mqtt", bytes([ka30_up]) + conn_ack() + sub_ack + publish(0x00, rebirth)
        + wait(0x81) + ping_resp + wait(0x8E))
    # The same as raw bytes, once whole and once one byte at a time.
    session = connack + suback + pub_rebirth + pingresp
    put("gateway_mqtt", bytes([ka30_up]) + raw(session) + wait(0x85))
    put("gateway_mqtt", bytes([ka4_bytewise]) + raw(session) + wait(0x85))
    # Commands: QoS 1 and 2 NCMD (PUBACK for QoS 1 only), a DCMD write, a
    # refused NCMD write, another node's NCMD, a built payload, QoS 3.
    put("gateway_mqtt", bytes([ka30_up]) + conn_ack() + sub_ack
        + publish(0x01, rebirth, pid=7) + publish(0x02, rebirth, pid=8)
        + publish(0x11, move, pid=9) + publish(0x00, reboot) + publish(0x20, rebirth)
        + publish(0x80, built=bytes([0x19, 0x40, 0x00]))   # ts, a metric, seq
        + publish(0x83, pid=10, built=bytes([0x02, 0xC0, 0x68, 0x02]) + b"ok")
        + wait(0x05) + publish(0x50, rebirth))
    # Keep-alive 1 s: a silent broker, a refusal (code 5), a CONNACK in
    # session, a close and a reset, the broker gone and back, a blackhole.
    put("gateway_mqtt", bytes([ka1_up]) + conn_ack() + sub_ack + wait(0x84)
        + conn_ack(5) + wait(0x81) + conn_ack() + conn_ack()
        + conn_ack() + close + wait(0x81) + conn_ack() + reset
        + listen + wait(0xC1) + listen + blackhole + wait(0x82) + blackhole + wait(0xC2)
        + conn_ack() + publish(0x00, rebirth))
    # Too long: skipped (a long PUBLISH, then a rebirth behind it); a
    # remaining length of 5 bytes ends the connection.
    put("gateway_mqtt", bytes([ka30_up]) + conn_ack() + sub_ack
        + oversized(0x00, b"\x08\x00") + publish(0x00, rebirth)
        + oversized(0x01, b"\xff\xff\xff\x7f") + reset + wait(0x82) + conn_ack() + oversized(0x03)
        + oversized(0x02) + wait(0x82) + conn_ack() + publish(0x00, rebirth))
    # The robot moves, its link drops and comes back, commands end: the
    # client publishes data, DDEATH and DBIRTH, command events.
    put("gateway_mqtt", bytes([ka30_up]) + conn_ack() + sub_ack + robot(1, 40) + wait(0x01)
        + robot(0, 0) + wait(0x01) + robot(0, 0) + robot(2, 0) + robot(3, 1) + wait(0x03)
        + publish(0x00, rebirth) + wait(0x40))
    # A primary host (setup bit 7): nothing published until its STATE says
    # online; another host's STATE is not its; offline ends the session.
    host_ka30_up = 0x93
    state_on, state_off = b'{"online":true,"timestamp":1700000000000}', b'{"timestamp":2,"online" : false}'
    put("gateway_mqtt", bytes([host_ka30_up]) + conn_ack() + bytes([0x02, 0x07, 0x00, 0x00, 0x80])
        + publish(0x70, state_on) + wait(0x01) + publish(0x00, rebirth)
        + publish(0x21, state_on, pid=3) + wait(0x02) + publish(0x00, rebirth)
        + publish(0xA0, built=b"\x04") + publish(0xA1, pid=4, built=b"\x09") + wait(0x81)
        + conn_ack() + publish(0x20, state_off) + wait(0x81) + conn_ack() + publish(0xA0, built=b"\x00"))



def enip_seeds():
    """Seeds of the hans-enip targets: a scanner's session (register, read
    the identity, open and close a class 1 connection), its CPF items and
    CIP requests, built from the specification's layouts."""
    def encap(cmd, session, data):
        return struct.pack("<HHII8sI", cmd, len(data), session, 0, b"seedctx!", 0) + data

    def cpf(items):
        return struct.pack("<H", len(items)) + b"".join(struct.pack("<HH", t, len(d)) + d for t, d in items)

    def rr(mr):
        return struct.pack("<IH", 0, 10) + cpf([(0x0000, b""), (0x00B2, mr)])

    def forward_open(large, serial, path):
        params = (lambda size: struct.pack("<I", 0x48000000 | size)) if large else (lambda size: struct.pack("<H", 0x4800 | size))
        body = struct.pack("<BBIIHHIB3sI", 0x0A, 0x0E, 0, 0x70000000 + serial, serial, 1, 0xCAFE, 2, b"", 10000)
        body += params(14) + struct.pack("<I", 10000) + params(10) + bytes([0x01, len(path) // 2]) + path
        return bytes([0x5B if large else 0x54, 2, 0x20, 0x06, 0x24, 0x01]) + body

    io_path = bytes([0x20, 0x04, 0x24, 151, 0x2C, 150, 0x2C, 100])
    key = bytes([0x34, 0x04]) + struct.pack("<HHHBB", 0xFFFE, 0x0C, 1, 0x81, 1)
    requests = [
        bytes([0x01, 2, 0x20, 0x01, 0x24, 0x01]),                     # Get_Attributes_All, Identity
        bytes([0x0E, 3, 0x20, 0xF5, 0x24, 0x01, 0x30, 0x05]),         # TCP/IP attribute 5
        bytes([0x10, 3, 0x20, 0x04, 0x24, 150, 0x30, 0x03]) + bytes(8),  # Set the output assembly
        forward_open(False, 1, io_path),
        forward_open(True, 2, key + io_path),
        bytes([0x4E, 2, 0x20, 0x06, 0x24, 0x01]) + struct.pack("<BBHHIBB", 0x0A, 0x0E, 1, 1, 0xCAFE, 2, 0) + io_path[:4],
    ]
    for r in requests:
        put("enip_cip", r)
        put("enip_cip", r[2 + 2 * r[1]:])  # the service data alone (Forward_Open as the parser sees it)
    # The first session handle of an adapter with Config::default()'s seed
    # (xorshift32 of 0x1F2E3D4C), so that the seeds get past the session check.
    x = 0x1F2E3D4C
    x ^= (x << 13) & 0xFFFFFFFF
    x ^= x >> 17
    x ^= (x << 5) & 0xFFFFFFFF
    session = x
    stream = encap(0x0065, 0, struct.pack("<HH", 1, 0)) + encap(0x0063, 0, b"")
    for r in requests:
        stream += encap(0x006F, session, rr(r))
    io = cpf([(0x8002, struct.pack("<II", 1, 1)), (0x00B1, struct.pack("<HI", 1, 1) + bytes(8))])
    for seed in (1, 7, 63):
        put("enip_stream", bytes([seed]) + stream)
    put("enip_stream", bytes([0]) + encap(0x0004, 0, b"") + encap(0x0064, 0, b"") + encap(0x0000, 0, b"x"))
    put("enip_cpf", rr(requests[0])[6:])
    put("enip_cpf", io)
    ident = struct.pack("<H", 1) + struct.pack(">HHI8s", 2, 44818, 0x7F000001, b"") + struct.pack(
        "<HHHBBHIB", 0xFFFE, 0x0C, 1, 1, 1, 0x30, 1, 4) + b"fuzz" + b"\x03"
    put("enip_cpf", cpf([(0x000C, ident)]))
    put("enip_cpf", cpf([(0x0100, struct.pack("<HH", 1, 0x120) + b"Communications\x00\x00")]))
    put("enip_cpf", cpf([(0x0000, b""), (0x00B2, requests[3]), (0x8001, struct.pack(">HHI8s", 2, 2222, 0, b""))]))

    # The audit export's paging: a query line, then stored records (audit
    # record version 1, gateway/src/audit/record.rs), each after its
    # length byte.
    def audit_record(seq, kind, actor=b"", detail=b""):
        body = bytes([1]) + struct.pack("<IIQI", seq, 1, seq * 1000, 0) + bytes([kind, 1]) + bytes(4)
        body += bytes([len(actor), len(detail)]) + actor + detail
        return body + struct.pack("<I", zlib.crc32(body))

    records = b"".join(
        bytes([len(r)]) + r
        for r in (audit_record(n, (6, 4, 10, 12)[n % 4], b"admin", b"link.poll_ms: 100 -> 50") for n in range(1, 40))
    )
    for query in (b"", b"before=20&limit=5", b"limit=32&format=csv", b"before=4294967295", b"before=0"):
        put("gateway_audit_page", query + b"\n" + records)


if __name__ == "__main__":
    sys.exit(main())
