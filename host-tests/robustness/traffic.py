#!/usr/bin/env python3
"""The rig's traffic generators that hping3 does not cover: frames crafted
with scapy and sent at a bounded rate for a bounded time, and TCP clients
that misbehave (connection exhaustion, zero-window and slow readers,
half-open connections, garbage replayed at a rate, RST/ACK injection).

    traffic.py KIND --iface IF --rate PPS --duration S [options]

Runs inside the rig's network namespace (root there): frames go out of the
TAP device IF to the emulated device only. Prints `ready` once its frames
are built (the rig starts the case's clock then), and a summary line
`sent N` at the end. Every loop ends at the deadline; nothing is retried
past it.
"""

import argparse
import os
import random
import socket
import struct
import subprocess
import sys
import time

from scapy.all import (ARP, BOOTP, DHCP, DNS, DNSQR, ICMP, IP, TCP, UDP, Dot1Q, Ether,
                       IPv6, ICMPv6ND_NS, Raw, fragment)

PORTS_OPEN = (502, 80)

# Every random choice comes from one seeded generator: a run's frames can be
# made again (--seed).
RNG = random.Random(1)


def rb(n):
    """`n` random bytes from the seeded generator."""
    return RNG.randbytes(n)


def rnd_mac(rng):
    # Locally administered unicast.
    return "02:%02x:%02x:%02x:%02x:%02x" % tuple(rng.randrange(256) for _ in range(5))


class Pacer:
    """Sends at most `rate` items a second until `duration` has passed."""

    def __init__(self, rate, duration):
        self.rate = rate
        self.end = time.monotonic() + duration
        self.start = time.monotonic()
        self.n = 0

    def go(self):
        """Waits for the next slot; False once the time is up."""
        now = time.monotonic()
        if now >= self.end:
            return False
        due = self.start + self.n / self.rate
        if due > now:
            time.sleep(min(due - now, self.end - now))
        self.n += 1
        return time.monotonic() < self.end


def blast(a, frames):
    """Sends `frames` (bytes) round-robin out of the TAP device."""
    s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW)
    s.bind((a.iface, 0))
    frames = [bytes(f) for f in frames]
    print("ready", flush=True)
    p = Pacer(a.rate, a.duration)
    sent = errors = 0
    i = 0
    while p.go():
        try:
            s.send(frames[i % len(frames)])
            sent += 1
        except OSError:
            errors += 1
        i += 1
    print(f"sent {sent} frames ({len(frames)} kinds), {errors} refused by the kernel", flush=True)


# --- frame sets ---------------------------------------------------------

def broadcast_storm(a, rng):
    fr = []
    for _ in range(64):
        ip = f"10.0.2.{rng.randrange(150, 250)}"
        fr.append(Ether(src=rnd_mac(rng), dst="ff:ff:ff:ff:ff:ff") /
                  ARP(op=1, hwsrc=a.own_mac, psrc=a.own_ip, pdst=ip))
        fr.append(Ether(src=a.own_mac, dst="ff:ff:ff:ff:ff:ff") /
                  IP(src=a.own_ip, dst=rng.choice(["255.255.255.255", "10.0.2.255"])) /
                  UDP(sport=rng.randrange(1024, 65535), dport=rng.randrange(1, 65535)) /
                  Raw(rb(rng.randrange(0, 200))))
        fr.append(Ether(src=rnd_mac(rng), dst="ff:ff:ff:ff:ff:ff", type=0x88B5) /
                  Raw(rb(rng.randrange(46, 1500))))
    return fr


def multicast_storm(a, rng):
    fr = []
    for _ in range(64):
        g = f"239.{rng.randrange(256)}.{rng.randrange(256)}.{rng.randrange(1, 255)}"
        o = [int(x) for x in g.split(".")]
        mac = "01:00:5e:%02x:%02x:%02x" % (o[1] & 0x7F, o[2], o[3])
        fr.append(Ether(src=a.own_mac, dst=mac) / IP(src=a.own_ip, dst=g) /
                  UDP(sport=5000, dport=rng.randrange(1, 65535)) / Raw(rb(64)))
        fr.append(Ether(src=a.own_mac, dst="01:00:5e:00:00:01") /
                  IP(src=a.own_ip, dst="224.0.0.1", ttl=1) / UDP(dport=rng.randrange(1, 65535)))
        fr.append(Ether(src=a.own_mac, dst="33:33:00:00:00:01") /
                  IPv6(src="fe80::1", dst="ff02::1") / ICMPv6ND_NS(tgt="fe80::5054:ff:fe12:3456"))
        # STP BPDU and LLDP (802.3 length / 0x88cc to the bridge groups).
        fr.append(Ether(src=rnd_mac(rng), dst="01:80:c2:00:00:00", type=0x0026) /
                  Raw(b"\x42\x42\x03" + rb(35)))
        fr.append(Ether(src=rnd_mac(rng), dst="01:80:c2:00:00:0e", type=0x88CC) /
                  Raw(rb(rng.randrange(46, 300))))
    return fr


def arp_flood(a, rng):
    fr = []
    for i in range(256):
        mac = rnd_mac(rng)
        src = f"10.0.2.{rng.randrange(150, 250)}"
        dst = "ff:ff:ff:ff:ff:ff" if i % 2 else a.device_mac
        fr.append(Ether(src=mac, dst=dst) / ARP(op=1, hwsrc=mac, psrc=src, pdst=a.device_ip))
    return fr


def arp_conflict(a, rng):
    fr = []
    for _ in range(32):
        mac = rnd_mac(rng)
        # Gratuitous request and reply for the device's own address.
        fr.append(Ether(src=mac, dst="ff:ff:ff:ff:ff:ff") /
                  ARP(op=1, hwsrc=mac, psrc=a.device_ip, pdst=a.device_ip))
        fr.append(Ether(src=mac, dst="ff:ff:ff:ff:ff:ff") /
                  ARP(op=2, hwsrc=mac, psrc=a.device_ip, hwdst="ff:ff:ff:ff:ff:ff", pdst=a.device_ip))
        # A reply to the device claiming its address; an ARP probe for it.
        fr.append(Ether(src=mac, dst=a.device_mac) /
                  ARP(op=2, hwsrc=mac, psrc=a.device_ip, hwdst=a.device_mac, pdst=a.device_ip))
        fr.append(Ether(src=mac, dst="ff:ff:ff:ff:ff:ff") /
                  ARP(op=1, hwsrc=mac, psrc="0.0.0.0", hwdst="00:00:00:00:00:00", pdst=a.device_ip))
        # Malformed ARP: wrong hardware/protocol lengths, truncated.
        fr.append(Ether(src=mac, dst=a.device_mac) /
                  ARP(op=1, hwlen=rng.choice([0, 4, 16]), plen=rng.choice([0, 6, 16]),
                      hwsrc=mac, psrc=a.own_ip, pdst=a.device_ip))
        fr.append(Ether(src=mac, dst=a.device_mac, type=0x0806) / Raw(rb(rng.randrange(0, 27))))
    return fr


def eth_malformed(a, rng):
    fr = []
    dev = a.device_mac
    for _ in range(32):
        # Runts: a header and less than the 46-byte minimum payload.
        fr.append(Ether(src=a.own_mac, dst=dev, type=rng.choice([0x0800, 0x0806, 0x88B5])) /
                  Raw(rb(rng.randrange(0, 46))))
        # Oversize: longer than 1514 bytes (the TAP's MTU is raised for it).
        fr.append(Ether(src=a.own_mac, dst=dev, type=0x0800) /
                  IP(src=a.own_ip, dst=a.device_ip) / UDP(dport=502) /
                  Raw(rb(rng.randrange(1500, 8000))))
        fr.append(Ether(src=a.own_mac, dst=dev, type=0x88B5) / Raw(rb(rng.choice([1515, 1518, 1522, 2048, 4096]))))
        # Unknown and odd EtherTypes; 802.3 length fields; VLAN tags.
        fr.append(Ether(src=a.own_mac, dst=dev, type=rng.choice([0x0000, 0x05DC, 0x0600, 0x88B5, 0x9000, 0xFFFF])) /
                  Raw(rb(rng.randrange(46, 1500))))
        fr.append(Ether(src=a.own_mac, dst=dev) / Dot1Q(vlan=rng.randrange(4096)) /
                  IP(src=a.own_ip, dst=a.device_ip) / ICMP())
        fr.append(Ether(src=a.own_mac, dst=dev) / Dot1Q(vlan=1) / Dot1Q(vlan=2) /
                  IP(src=a.own_ip, dst=a.device_ip) / TCP(dport=502, flags="S"))
        fr.append(Ether(src=a.own_mac, dst=dev, type=0x86DD) / Raw(rb(rng.randrange(40, 200))))
    return fr


def ipv4_malformed(a, rng):
    fr = []
    eth = lambda: Ether(src=a.own_mac, dst=a.device_mac)  # noqa: E731
    for _ in range(32):
        base = IP(src=a.own_ip, dst=a.device_ip) / ICMP() / Raw(rb(32))
        b = bytearray(bytes(base))
        b[10:12] = rb(2)                      # bad header checksum
        fr.append(eth() / Raw(bytes(b)))
        for ihl in (0, 1, 4, 15):                     # IHL too small or past the packet
            fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, ihl=ihl) / UDP(dport=502))
        for tl in (0, 19, 20, 21, 1500, 65535):       # total length wrong both ways
            fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, len=tl) / TCP(dport=502, flags="S"))
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, version=rng.choice([0, 5, 6, 15])) / ICMP())
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, ihl=15, options=[]) / Raw(rb(60)))
        fr.append(eth() / IP(src=a.device_ip, dst=a.device_ip) / TCP(sport=502, dport=502, flags="S"))  # land
        fr.append(eth() / IP(src="255.255.255.255", dst=a.device_ip) / ICMP())
        fr.append(eth() / IP(src="0.0.0.0", dst=a.device_ip) / UDP(dport=68))
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, ttl=0) / ICMP())
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, proto=rng.choice([0, 2, 41, 47, 50, 132, 253, 255])) /
                  Raw(rb(40)))
        # Bad transport checksums; truncated TCP/UDP headers.
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip) / TCP(dport=502, flags="S", chksum=rng.randrange(65536)))
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip) / UDP(dport=68, chksum=rng.randrange(1, 65536)) / Raw(b"x" * 20))
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, proto=6) / Raw(rb(rng.randrange(0, 20))))
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, proto=17) / Raw(rb(rng.randrange(0, 8))))
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip) / TCP(dport=80, dataofs=rng.choice([0, 4, 15]), flags="S"))
    return fr


def ipv4_fragments(a, rng):
    fr = []
    eth = lambda: Ether(src=a.own_mac, dst=a.device_mac)  # noqa: E731
    for _ in range(32):
        ident = rng.randrange(65536)
        payload = bytes(ICMP(id=rng.randrange(65536)) / Raw(rb(3000)))
        # Overlapping: the same bytes sent at overlapping offsets.
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, id=ident, flags="MF", frag=0, proto=1) / Raw(payload[:800]))
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, id=ident, flags="MF", frag=50, proto=1) / Raw(payload[400:1200]))
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, id=ident, frag=100, proto=1) / Raw(payload[800:1000]))
        # Tiny: 8 bytes a fragment, the TCP header split.
        tcp = bytes(TCP(dport=502, flags="S"))
        ident = rng.randrange(65536)
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, id=ident, flags="MF", frag=0, proto=6) / Raw(tcp[:8]))
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, id=ident, frag=1, proto=6) / Raw(tcp[8:]))
        # Never completed: a first fragment alone; a middle one alone.
        fr.append(eth() / IP(src=f"10.0.2.{rng.randrange(150, 250)}", dst=a.device_ip, id=rng.randrange(65536),
                             flags="MF", frag=0, proto=17) / Raw(rb(1400)))
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, id=rng.randrange(65536), flags="MF",
                             frag=rng.randrange(1, 8000), proto=1) / Raw(rb(1000)))
        # Past 65535 bytes when reassembled (ping of death's last piece).
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip, id=rng.randrange(65536), frag=8189, proto=1) /
                  Raw(rb(1000)))
    return fr


def icmp_oversize(a, rng):
    fr = []
    eth = lambda: Ether(src=a.own_mac, dst=a.device_mac)  # noqa: E731
    for _ in range(8):
        # The largest echo that fits a frame, and a 65,000-byte one in fragments.
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip) / ICMP(id=7, seq=rng.randrange(65536)) / Raw(rb(1472)))
        big = IP(src=a.own_ip, dst=a.device_ip, id=rng.randrange(65536)) / ICMP(id=8) / Raw(rb(65000))
        fr += [eth() / f for f in fragment(big, fragsize=1480)[:6]]
        # Unknown types and codes, bad checksums, errors quoting the PLC's session.
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip) / ICMP(type=rng.randrange(256), code=rng.randrange(256)) /
                  Raw(rb(rng.randrange(0, 100))))
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip) / ICMP(chksum=rng.randrange(65536)) / Raw(b"y" * 56))
        quote = bytes(IP(src=a.device_ip, dst=a.plc_ip) / TCP(sport=502, dport=rng.randrange(32768, 61000)))[:28]
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip) / ICMP(type=3, code=4, nexthopmtu=68) / Raw(quote))
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip) / ICMP(type=5, code=1, gw="10.0.2.66") / Raw(quote))
    return fr


def tcp_flags(a, rng):
    fr = []
    eth = lambda: Ether(src=a.own_mac, dst=a.device_mac)  # noqa: E731
    combos = ["", "F", "SF", "SR", "SFR", "FPU", "SFPU", "SRPAUEC", "R", "RA", "FA", "PA", "U", "SA", "SFA", "SEC"]
    for port in (502, 80, 5021, 23, 4444):
        for f in combos:
            fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip) /
                      TCP(sport=rng.randrange(1024, 65535), dport=port, flags=f, seq=rng.randrange(2**32),
                          ack=rng.randrange(2**32), urgptr=rng.randrange(65536)) /
                      Raw(rb(rng.choice([0, 0, 10]))))
        # Options garbage, a SYN with payload.
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip) /
                  TCP(dport=port, flags="S", options=[("MSS", 0), ("WScale", 255), ("SAckOK", b""), ("NOP", None)]))
        fr.append(eth() / IP(src=a.own_ip, dst=a.device_ip) / TCP(dport=port, flags="S") / Raw(rb(100)))
    return fr


def dhcp_dns_garbage(a, rng):
    fr = []
    mac_b = bytes(int(x, 16) for x in a.device_mac.split(":"))
    for i in range(48):
        xid = rng.randrange(2**32)
        mtype = rng.choice(["offer", "ack", "nak", "request", "decline", "inform", 0, 9, 200])
        opts = [("message-type", mtype), ("server_id", "10.0.2.66"), ("lease_time", rng.randrange(2**32)),
                ("subnet_mask", "255.0.0.0"), ("router", "10.0.2.66"), "end"]
        dst_mac = "ff:ff:ff:ff:ff:ff" if i % 2 else a.device_mac
        dst_ip = "255.255.255.255" if i % 2 else a.device_ip
        fr.append(Ether(src=a.own_mac, dst=dst_mac) / IP(src="10.0.2.66", dst=dst_ip) /
                  UDP(sport=67, dport=68) /
                  BOOTP(op=2, xid=xid, yiaddr=f"10.0.2.{rng.randrange(150, 250)}", chaddr=mac_b) / DHCP(options=opts))
        # Truncated options, option lengths past the end, a wrong magic cookie, garbage.
        bootp = bytes(BOOTP(op=2, xid=xid, chaddr=mac_b))
        fr.append(Ether(src=a.own_mac, dst=dst_mac) / IP(src="10.0.2.66", dst=dst_ip) / UDP(sport=67, dport=68) /
                  Raw(bootp + b"\x63\x82\x53\x63" + bytes([53, 1, 2, 54, 4, 10, 0, 2, 66, 51, 200]) + rb(rng.randrange(0, 40))))
        fr.append(Ether(src=a.own_mac, dst=dst_mac) / IP(src="10.0.2.66", dst=dst_ip) / UDP(sport=67, dport=68) /
                  Raw(bootp[:rng.randrange(0, len(bootp))]))
        fr.append(Ether(src=a.own_mac, dst=dst_mac) / IP(src="10.0.2.66", dst=dst_ip) / UDP(sport=67, dport=68) /
                  Raw(bootp + b"\xde\xad\xbe\xef" + rb(60)))
        fr.append(Ether(src=a.own_mac, dst=dst_mac) / IP(src="10.0.2.66", dst=dst_ip) / UDP(sport=67, dport=68) /
                  Raw(bootp + b"\x63\x82\x53\x63" + bytes([rng.randrange(256) for _ in range(rng.randrange(1, 300))])))
        # DNS answers nobody asked for, and garbage, to the device's ports.
        fr.append(Ether(src=a.own_mac, dst=a.device_mac) / IP(src=a.own_ip, dst=a.device_ip) /
                  UDP(sport=53, dport=rng.randrange(1024, 65535)) /
                  DNS(id=rng.randrange(65536), qr=1, qd=DNSQR(qname="pool.ntp.org"), ancount=rng.randrange(65536)))
        fr.append(Ether(src=a.own_mac, dst=a.device_mac) / IP(src=a.own_ip, dst=a.device_ip) /
                  UDP(sport=53, dport=rng.choice([53, 68, 123, 5353, rng.randrange(1024, 65535)])) /
                  Raw(rb(rng.randrange(0, 512))))
    return fr


FRAME_SETS = {
    "broadcast": broadcast_storm,
    "multicast": multicast_storm,
    "arp-flood": arp_flood,
    "arp-conflict": arp_conflict,
    "eth-malformed": eth_malformed,
    "ipv4-malformed": ipv4_malformed,
    "ipv4-fragments": ipv4_fragments,
    "icmp-oversize": icmp_oversize,
    "tcp-flags": tcp_flags,
    "dhcp-dns": dhcp_dns_garbage,
}


# --- TCP clients --------------------------------------------------------

def connect(dst, port, src, timeout=1.0, rcvbuf=None):
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if rcvbuf:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
    s.bind((src, 0))
    s.settimeout(timeout)
    try:
        s.connect((dst, port))
    except OSError:
        s.close()
        return None
    return s


def exhaust(a, rng):
    """Opens connections to 502 and 80 from every source address and holds
    them, silent; reopens what the device closes, at most `rate` a second."""
    print("ready", flush=True)
    held = []
    p = Pacer(a.rate, a.duration)
    opened = 0
    while p.go():
        held = [(s, port) for (s, port) in held if alive(s)]
        if len(held) >= 32:
            continue
        src = rng.choice(a.sources)
        port = rng.choice(PORTS_OPEN)
        s = connect(a.device_ip, port, src, timeout=0.3)
        if s:
            opened += 1
            held.append((s, port))
    for s, _ in held:
        s.close()
    print(f"sent {opened} connections opened", flush=True)


def alive(s):
    """False once the device closed it (the socket is then closed here)."""
    try:
        s.setblocking(False)
        data = s.recv(4096)
        if data == b"":
            s.close()
            return False
        return True
    except BlockingIOError:
        return True
    except OSError:
        s.close()
        return False


def slow_clients(a, rng):
    """Zero-window and slow-reading clients: each asks for the page (80) or
    for 125 registers again and again (502), with a tiny receive buffer; half
    never read (the window closes), half read 16 bytes a tick."""
    print("ready", flush=True)
    get = b"GET / HTTP/1.1\r\nHost: %s\r\nAccept-Encoding: gzip\r\n\r\n" % a.device_ip.encode()
    readmb = struct.pack(">HHHBBHH", 1, 0, 6, 1, 3, 0, 55)
    clients = []
    p = Pacer(a.rate, a.duration)
    opened = 0
    while p.go():
        clients = [c for c in clients if c[0].fileno() != -1]
        for s, port, reader in clients:
            try:
                s.setblocking(False)
                if port == 502:
                    s.send(readmb * 8)
                else:
                    s.send(get)
                if reader:
                    s.recv(16)
            except BlockingIOError:
                pass
            except OSError:
                s.close()
        if len(clients) < 12:
            port = rng.choice(PORTS_OPEN)
            s = connect(a.device_ip, port, rng.choice(a.sources), timeout=0.3, rcvbuf=256)
            if s:
                opened += 1
                clients.append((s, port, len(clients) % 2 == 1))
    for s, _, _ in clients:
        s.close()
    print(f"sent {opened} slow clients", flush=True)


def half_open(a, rng):
    """Connections whose client vanishes without FIN or RST: opened from
    the addresses `--sources`, which are then removed from the TAP device
    (the kernel no longer answers for them), and held until the end."""
    held = []
    for src in a.sources:
        for port in PORTS_OPEN:
            for _ in range(2):
                s = connect(a.device_ip, port, src)
                if s:
                    if port == 80:
                        s.send(b"GET / HTTP/1.1\r\nHost: %s\r\n" % a.device_ip.encode())  # half a request
                    else:
                        s.send(b"\x00\x01\x00\x00")                                       # half a header
                    held.append(s)
    for src in a.sources:
        subprocess.run(["ip", "addr", "del", f"{src}/24", "dev", a.iface], check=False)
    print("ready", flush=True)
    time.sleep(a.duration)
    print(f"sent {len(held)} half-open connections", flush=True)
    os._exit(0)  # leave the kernel's sockets to die with their addresses


def corpus_entries(path, strip_first):
    out = []
    if path and os.path.isdir(path):
        for name in sorted(os.listdir(path)):
            with open(os.path.join(path, name), "rb") as f:
                data = f.read()
            if strip_first:
                data = data[1:]
            if data:
                out.append(data)
    return out


WRITE_FCS = {5, 6, 15, 16, 23}


def modbus_without_writes(stream):
    """The stream with every Modbus write request that could be accepted
    left out: Modbus/TCP has no authentication, a write the gateway accepts
    is what any allowed client may do (access control is the allow-lists,
    write protection and TLS roles, not robustness). Frames that are not
    well formed are kept, whatever they claim to be."""
    out = b""
    i = 0
    while i < len(stream):
        head = stream[i:i + 8]
        if len(head) < 8:
            out += stream[i:]
            break
        proto, length = struct.unpack(">HH", head[2:6])
        fc = head[7]
        if proto != 0 or length < 2 or length > 254:
            out += stream[i:]
            break
        frame = stream[i:i + 6 + length]
        if fc not in WRITE_FCS:
            out += frame
        i += 6 + length
    return out


def generated_modbus(rng):
    out = []
    for _ in range(200):
        kind = rng.randrange(6)
        if kind == 0:
            out.append(rb(rng.randrange(1, 300)))
        elif kind == 1:       # a header whose length lies
            out.append(struct.pack(">HHHB", rng.randrange(65536), 0, rng.randrange(65536), 1) + rb(rng.randrange(0, 260)))
        elif kind == 2:       # reads of every size, some out of range
            out.append(struct.pack(">HHHBBHH", 1, 0, 6, 1, rng.choice([1, 2, 3, 4]), rng.randrange(65536), rng.randrange(65536)))
        elif kind == 3:       # writes to read-only and unmapped addresses (refused)
            addr = rng.choice([0, 1, 3, 47, 60, 99, 9000, 65535])
            out.append(struct.pack(">HHHBBHHB", 1, 0, 9, 1, 16, addr, 1, 2) + rb(2))
        elif kind == 4:       # unknown function codes
            out.append(struct.pack(">HHHBB", 1, 0, 2 + 4, 1, rng.choice([0, 7, 8, 17, 43, 90, 127, 128, 255])) + rb(4))
        else:                 # not Modbus: protocol id != 0
            out.append(struct.pack(">HHHB", 1, rng.randrange(1, 65536), 6, 1) + rb(6))
    return out


def generated_http(rng):
    host = b"Host: 10.0.2.15\r\n"
    out = []
    for _ in range(200):
        kind = rng.randrange(6)
        if kind == 0:
            out.append(rb(rng.randrange(1, 2000)))
        elif kind == 1:
            out.append(b"GET /" + rb(rng.randrange(0, 3000)) + b" HTTP/1.1\r\n" + host + b"\r\n")
        elif kind == 2:
            out.append(b"POST /api/login HTTP/1.1\r\n" + host + b"Content-Length: 99999999\r\n\r\n{")
        elif kind == 3:
            out.append(b"GET / HTTP/1.1\r\n" + b"X: " + b"a" * rng.randrange(100, 5000) + b"\r\n" + host + b"\r\n")
        elif kind == 4:
            out.append(b"POST /api/config HTTP/1.1\r\n" + host + b"Transfer-Encoding: chunked\r\n\r\nzz\r\n")
        else:
            out.append(rng.choice([b"\r\n" * 500, b"GET", b"HEAD / HTTP/9.9\r\n\r\n", b"GET / HTTP/1.1\r\nHost: evil\r\n\r\n"]))
    return out


def replay(a, rng, port):
    """Replays fuzz-corpus entries (or generated garbage) over new TCP
    connections, `rate` connections a second."""
    if port == 502:
        entries = [modbus_without_writes(e) for e in corpus_entries(a.corpus, True)]
        entries = [e for e in entries if e]
        source = f"corpus {a.corpus} ({len(entries)} entries, accepted writes left out)" if entries else ""
        entries += generated_modbus(rng)
    else:
        entries = corpus_entries(a.corpus, True)
        source = f"corpus {a.corpus} ({len(entries)} entries)" if entries else ""
        entries += generated_http(rng)
    rng.shuffle(entries)
    print("ready", flush=True)
    p = Pacer(a.rate, a.duration)
    n = refused = 0
    while p.go():
        s = connect(a.device_ip, port, rng.choice(a.sources), timeout=0.2)
        if s is None:
            refused += 1
            continue
        try:
            s.settimeout(0.05)
            s.sendall(entries[n % len(entries)])
            s.recv(4096)
        except OSError:
            pass
        finally:
            s.close()
        n += 1
    print(f"sent {n} connections of garbage ({source or 'generated only'}), {refused} not accepted", flush=True)


# --- injection into the PLC's session ----------------------------------

def inject(a, rng, mode):
    """Sniffs the PLC's session (device:502 -> PLC) on the TAP device and
    injects segments as the PLC. `right`: a RST with exactly the sequence
    number the device expects (ends the session, as TCP must). `window`:
    RSTs inside the receive window but not exact (RFC 5961 asks for a
    challenge ACK; RFC 793 accepted them). `wrong`: RSTs outside the
    window, ACKs of data never sent, out-of-window ACKs, SYNs."""
    rx = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(0x0800))
    rx.bind((a.iface, 0))
    rx.settimeout(0.2)
    tx = socket.socket(socket.AF_PACKET, socket.SOCK_RAW)
    tx.bind((a.iface, 0))
    print("ready", flush=True)
    p = Pacer(a.rate, a.duration)
    sent = 0
    while p.go():
        # The session's state when it falls quiet (5 ms without a segment,
        # as between two of the PLC's polls): the sequence number the device
        # expects next is the ack of its last segment, or the end of the
        # PLC's last one. Read from the raw bytes: parsing with scapy would
        # take longer than the PLC's pause.
        seg = None
        dev, plc = socket.inet_aton(a.device_ip), socket.inet_aton(a.plc_ip)
        end = time.monotonic() + 0.5
        rx.settimeout(0.2)
        while time.monotonic() < end:
            try:
                raw = rx.recv(2048)
            except socket.timeout:
                if seg is not None:
                    break
                continue
            if len(raw) < 54 or raw[12:14] != b"\x08\x00" or raw[23] != 6:
                continue
            ihl = (raw[14] & 15) * 4
            total = struct.unpack(">H", raw[16:18])[0]
            tcp = raw[14 + ihl:14 + total]
            if len(tcp) < 20:
                continue
            sport, dport, sq, ak = struct.unpack(">HHII", tcp[:12])
            payload = len(tcp) - (tcp[12] >> 4) * 4
            if raw[26:30] == dev and raw[30:34] == plc and sport == 502:
                seg = (dport, ak, sq + payload)
            elif raw[26:30] == plc and raw[30:34] == dev and dport == 502:
                seg = (sport, (sq + payload) & 0xFFFFFFFF, ak)
            else:
                continue
            rx.settimeout(0.005)
        if seg is None:
            continue
        plc_port, expect, their = seg
        t = TCP(sport=plc_port)
        mk = lambda **kw: bytes(Ether(src=a.own_mac, dst=a.device_mac) /  # noqa: E731
                                IP(src=a.plc_ip, dst=a.device_ip) / TCP(sport=t.sport, dport=502, **kw))
        if mode == "right":
            frames = [mk(flags="R", seq=expect)]
        elif mode == "window":
            frames = [mk(flags="R", seq=(expect + 100) & 0xFFFFFFFF),
                      mk(flags="RA", seq=(expect + 1) & 0xFFFFFFFF, ack=their)]
        else:
            frames = [mk(flags="R", seq=(expect + 10_000_000) & 0xFFFFFFFF),
                      mk(flags="R", seq=(expect - 10_000_000) & 0xFFFFFFFF),
                      mk(flags="RA", seq=(expect + 20_000_000) & 0xFFFFFFFF, ack=their),
                      mk(flags="A", seq=expect, ack=(their + 5_000_000) & 0xFFFFFFFF),
                      mk(flags="A", seq=(expect + 3_000_000) & 0xFFFFFFFF, ack=their),
                      mk(flags="S", seq=rng.randrange(2**32))]
        for f in frames:
            tx.send(f)
            sent += 1
    print(f"sent {sent} injected segments", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("kind")
    ap.add_argument("--iface", required=True)
    ap.add_argument("--rate", type=float, required=True)
    ap.add_argument("--duration", type=float, required=True)
    ap.add_argument("--device-ip", default="10.0.2.15")
    ap.add_argument("--device-mac", default="52:54:00:12:34:56")
    ap.add_argument("--own-ip", default="10.0.2.2")
    ap.add_argument("--plc-ip", default="10.0.2.10")
    ap.add_argument("--sources", default="10.0.2.20", help="comma list of local source addresses")
    ap.add_argument("--corpus", default=None)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    a.sources = a.sources.split(",")
    with open(f"/sys/class/net/{a.iface}/address") as f:
        a.own_mac = f.read().strip()
    RNG.seed(a.seed)
    rng = RNG
    if a.kind in FRAME_SETS:
        blast(a, FRAME_SETS[a.kind](a, rng))
    elif a.kind == "exhaust":
        exhaust(a, rng)
    elif a.kind == "slow":
        slow_clients(a, rng)
    elif a.kind == "half-open":
        half_open(a, rng)
    elif a.kind == "modbus-garbage":
        replay(a, rng, 502)
    elif a.kind == "http-garbage":
        replay(a, rng, 80)
    elif a.kind in ("inject-wrong", "inject-window", "inject-right"):
        inject(a, rng, a.kind.split("-")[1])
    else:
        sys.exit(f"traffic.py: unknown kind {a.kind}")


if __name__ == "__main__":
    main()
