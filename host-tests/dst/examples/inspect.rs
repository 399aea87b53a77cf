//! Replays a seed and shows the state when it fails:
//! `cargo run --release -p hans-dst --example inspect -- SEED STEPS`.
use hans_gateway::job::Source;
fn main() {
    let seed: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let steps: usize = std::env::args()
        .nth(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(200);
    let mut s = hans_dst::Scenario::new(seed);
    for n in 0..steps {
        if let Err(f) = s.step(n) {
            println!("{f}");
            break;
        }
    }
    let r = s.drain(steps);
    let w = &s.world;
    w.model(|m| {
        for src in Source::all() {
            let h = m.handshake(src).unwrap();
            if h.is_busy() {
                println!(
                    "{src:?}: {:?} echo {} code {}",
                    h.phase, h.seq_echo, h.command_echo
                );
            }
        }
        println!(
            "active {:?} queue {:?} link {:?}",
            m.active_motion,
            m.queue.sources().collect::<Vec<_>>(),
            m.link
        );
    });
    println!(
        "robot fsm {} in motion {} estop {} error {:?}",
        w.robot.model.fsm,
        w.robot.model.in_motion(),
        w.robot.model.estop,
        w.robot.model.error
    );
    for m in w
        .robot
        .log
        .iter()
        .rev()
        .filter(|m| !m.text.starts_with("Read"))
        .take(15)
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
    {
        println!("  {} {}", m.at.as_millis(), m.text);
    }
    if let Err(f) = r {
        println!("{}", f.what);
    }
}
