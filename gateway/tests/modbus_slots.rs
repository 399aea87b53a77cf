//! Modbus session slots under attack (issue 16, classes 4 and 5), in
//! virtual time: a frame must be whole within 1 s of its first byte, one
//! address gets at most 2 of the 4 sessions, a newcomer takes the slot of
//! the longest-idle session, and applying an allow-list closes the
//! sessions it no longer permits before they are served again.

use core::net::Ipv4Addr;

use embassy_time::{Duration, Instant};
use hans_gateway::registers as r;
use hans_gateway::testkit::plc::{pdu, Answer};
use hans_gateway::testkit::world::{World, WorldConfig};

/// `modbus::FRAME_DEADLINE`.
const FRAME_DEADLINE: Duration = Duration::from_secs(1);
/// `modbus::EVICT_IDLE`.
const EVICT_IDLE: Duration = Duration::from_secs(2);

fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

fn ip(last: u8) -> Ipv4Addr {
    Ipv4Addr::new(10, 0, 0, last)
}

/// A world with `plcs` PLCs (from 10.0.0.10 on), its first status round
/// done.
fn world(plcs: usize) -> World {
    let mut w = World::new(WorldConfig {
        plcs,
        ..WorldConfig::default()
    });
    w.run_for(ms(300));
    w
}

/// PLC `i` sends `pdu`; the world runs until the answer comes, at most
/// `limit`: the answer and when it came, or `None`.
fn ask_within(w: &mut World, i: usize, pdu: &[u8], limit: Duration) -> Option<(Answer, Instant)> {
    let tid = w.plcs[i].send(pdu);
    let end = w.now() + limit;
    loop {
        w.catch_up();
        if let Some(a) = w.plcs[i].answer(tid) {
            return Some((a, w.now()));
        }
        if w.now() >= end {
            return None;
        }
        w.run_for(ms(10));
    }
}

fn sessions(w: &mut World, i: usize) -> u16 {
    match w.request(i, &pdu::read(r::STATUS_SESSIONS, 1)) {
        Answer::Pdu(p) => pdu::registers(&p)[0],
        Answer::Exception(e) => panic!("STATUS_SESSIONS: exception {e}"),
    }
}

/// What a slow attacker sends: the MBAP header of the longest Modbus
/// frame, then its body, a byte at a time.
fn trickle(at: usize) -> u8 {
    [0, 1, 0, 0, 0, 254, 1, 16].get(at).copied().unwrap_or(0)
}

/// Attacker `k` (from `from`): one more byte if its connection is open,
/// else it connects again and sends the first three.
fn attack(w: &mut World, socks: &mut [(usize, usize)], k: usize, from: Ipv4Addr) {
    let (s, at) = socks[k];
    if w.plc_open(s) {
        w.plcs[s].send_raw(&[trickle(at)]);
        socks[k] = (s, at + 1);
    } else {
        let s = w.connect_plc(from);
        w.plcs[s].send_raw(&[trickle(0), trickle(1), trickle(2)]);
        socks[k] = (s, 3);
    }
}

#[test]
fn partial_headers_from_four_sockets_keep_a_plc_out_no_longer_than_the_frame_deadline() {
    let mut w = world(0);
    // Four sockets from four addresses each send the first bytes of an
    // MBAP header, then one byte every 500 ms (each read comes well within
    // the 120 s idle timeout, and the frame would take two minutes);
    // whichever is closed connects again at once and starts over.
    let attackers: Vec<Ipv4Addr> = (60..64).map(ip).collect();
    let mut socks = vec![(usize::MAX, 0); attackers.len()];
    for (k, a) in attackers.iter().enumerate() {
        attack(&mut w, &mut socks, k, *a);
    }
    w.run_for(ms(300));
    assert!(
        socks.iter().all(|&(s, _)| w.plc_open(s)),
        "all four were taken"
    );

    // The PLC comes.
    let plc = w.connect_plc(ip(10));
    let came = w.now();
    let tid = w.plcs[plc].send(&pdu::read(r::STATUS_VERSION, 1));
    let mut answered = None;
    for step in 0..300 {
        w.run_for(ms(100));
        if let Some(a) = w.plcs[plc].answer(tid) {
            answered = Some((a, w.now()));
            break;
        }
        for (k, a) in attackers.iter().enumerate() {
            if step % 5 == 0 || !w.plc_open(socks[k].0) {
                attack(&mut w, &mut socks, k, *a);
            }
        }
    }
    let (answer, at) = answered.expect("the PLC is served while the trickle goes on");
    assert!(matches!(answer, Answer::Pdu(_)), "{answer:?}");
    assert!(
        at - came <= FRAME_DEADLINE,
        "served {} ms after it came, not within the frame deadline",
        (at - came).as_millis()
    );
    // And it stays served while the attackers go on.
    for _ in 0..5 {
        for _ in 0..7 {
            w.run_for(ms(100));
            for (k, a) in attackers.iter().enumerate() {
                attack(&mut w, &mut socks, k, *a);
            }
        }
        assert!(matches!(
            ask_within(&mut w, plc, &pdu::read(r::STATUS_VERSION, 1), ms(100)),
            Some((Answer::Pdu(_), _))
        ));
    }
}

#[test]
fn one_address_gets_at_most_three_sessions() {
    let mut w = world(0);
    // 10.0.0.66 opens five sessions, each asking at once: the newest
    // connection of an address wins, its least recently active one goes.
    let mut from_66 = Vec::new();
    for _ in 0..5 {
        let s = w.connect_plc(ip(66));
        let _ = ask_within(&mut w, s, &pdu::read(r::STATUS_VERSION, 1), ms(100));
        from_66.push(s);
    }
    let open: Vec<bool> = from_66.iter().map(|&s| w.plc_open(s)).collect();
    assert_eq!(
        open,
        [false, false, true, true, true],
        "the fourth and fifth took the places of the first and second"
    );
    // Another address still gets the last slot, at once.
    let plc = w.connect_plc(ip(10));
    assert!(matches!(
        ask_within(&mut w, plc, &pdu::read(r::STATUS_VERSION, 1), ms(100)),
        Some((Answer::Pdu(_), _))
    ));
    // A client that connects for each request (and closes) is served each
    // time, whether or not the gateway has seen its last connection close.
    for _ in 0..3 {
        let again = w.connect_plc(ip(66));
        assert!(matches!(
            ask_within(&mut w, again, &pdu::read(r::STATUS_VERSION, 1), ms(100)),
            Some((Answer::Pdu(_), _))
        ));
        from_66.push(again);
    }
    assert!(w.plc_open(plc), "the other address keeps its session");
    let open: Vec<usize> = from_66.iter().copied().filter(|&s| w.plc_open(s)).collect();
    assert_eq!(open.len(), 3, "never more than three of 10.0.0.66");
    // All three in the middle of a frame: a fourth is closed at once, and
    // none of them is disturbed.
    for &s in &open {
        w.plcs[s].send_raw(&[0, 9, 0, 0]);
    }
    w.run_for(ms(10));
    let fourth = w.connect_plc(ip(66));
    w.run_for(ms(50));
    assert!(!w.plc_open(fourth), "a fourth is closed at once");
    assert!(open.iter().all(|&s| w.plc_open(s)) && w.plc_open(plc));
}

#[test]
fn a_new_client_takes_the_slot_of_the_longest_idle_session() {
    let mut w = world(4);
    // Last requests: PLC 2, then 0, 3, 1, half a second apart.
    for i in [2, 0, 3, 1] {
        w.request(i, &pdu::read(r::STATUS_VERSION, 1));
        w.run_for(ms(500));
    }
    w.run_for(EVICT_IDLE);
    assert_eq!(sessions(&mut w, 1), 4);
    let newcomer = w.connect_plc(ip(20));
    let got = ask_within(&mut w, newcomer, &pdu::read(r::STATUS_VERSION, 1), ms(100));
    assert!(
        matches!(got, Some((Answer::Pdu(_), _))),
        "the newcomer is served at once: {got:?}"
    );
    let open: Vec<bool> = (0..4).map(|i| w.plc_open(i)).collect();
    assert_eq!(open, [true, true, false, true], "PLC 2, idle longest, went");
    assert_eq!(sessions(&mut w, 1), 4);

    // A session in the middle of a frame is not idle: when the next
    // newcomer comes, PLC 0 (idle longest) has sent half a request; PLC 3
    // (idle next longest) goes instead, and PLC 0's request, whole within
    // the frame deadline, is answered.
    w.run_for(EVICT_IDLE);
    let frame = [0, 9, 0, 0, 0, 6, 1, 3, 0, 0, 0, 1];
    w.plcs[0].send_raw(&frame[..5]);
    w.run_for(ms(100));
    let second = w.connect_plc(ip(21));
    let got = ask_within(&mut w, second, &pdu::read(r::STATUS_VERSION, 1), ms(100));
    assert!(matches!(got, Some((Answer::Pdu(_), _))), "{got:?}");
    let open: Vec<bool> = (0..4).map(|i| w.plc_open(i)).collect();
    assert_eq!(open, [true, true, false, false], "PLC 3 went, not PLC 0");
    w.run_for(ms(500));
    w.plcs[0].send_raw(&frame[5..]);
    w.run_for(ms(50));
    assert!(
        matches!(w.plcs[0].answer(9), Some(Answer::Pdu(_))),
        "PLC 0's frame, whole within the deadline, is answered"
    );
}

#[test]
fn applying_an_allow_list_closes_the_sessions_it_no_longer_permits() {
    let mut w = world(2);
    w.add_admin(); // a commissioned device
    w.allow_modbus_config(); // whose access settings may change over Modbus
    let before = w.reg(r::CONFIG_POLL_MS);
    // PLC 0 (10.0.0.10) allows only itself and applies.
    w.set(r::MODBUS_ALLOW, &[0x0A00, 0x000A, 32]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    w.run_for(ms(10));
    assert!(
        !w.plc_open(1),
        "PLC 1 (10.0.0.11) is closed after the apply"
    );
    // What it sends now is not executed.
    let got = ask_within(
        &mut w,
        1,
        &pdu::write_one(r::CONFIG_POLL_MS, before + 7),
        ms(500),
    );
    assert_eq!(got, None, "no answer");
    assert_eq!(
        w.reg(r::CONFIG_POLL_MS),
        before,
        "its write was not executed"
    );
    assert!(w.plc_open(0));
    assert_eq!(sessions(&mut w, 0), 1);
}
