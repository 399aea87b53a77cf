//! Replays a seed up to a step and prints the robot's requests from a
//! time on, with channel 1's phase at the end:
//! `cargo run --release -p hans-dst --example robot_log -- SEED STEP FROM_MS`.
use hans_gateway::job::Source;
fn main() {
    let a: Vec<u64> = std::env::args()
        .skip(1)
        .filter_map(|s| s.parse().ok())
        .collect();
    let (seed, upto, from) = (a[0], a[1] as usize, a[2]);
    let mut s = hans_dst::Scenario::new(seed);
    for n in 0..upto {
        if let Err(f) = s.step(n) {
            println!("{}", f.what);
            break;
        }
    }
    let w = &s.world;
    for m in w.robot.log.iter().filter(|m| m.at.as_millis() >= from) {
        println!(
            "{:>9.3} conn {} {}",
            m.at.as_micros() as f64 / 1000.0,
            m.conn,
            m.text
        );
    }
    for src in [Source::Channel(0), Source::Channel(1)] {
        println!("{src:?}: {:?}", w.model(|m| m.handshake(src).copied()));
    }
    println!("robot jog {:?}", w.robot.model.jog);
}
