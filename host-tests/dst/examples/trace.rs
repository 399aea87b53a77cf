//! Replays a seed up to a step, then turn by turn prints the robot's state
//! and a channel's phase: `cargo run --release -p hans-dst --example trace -- SEED STEP UNTIL_MS`.
use embassy_time::Instant;
use hans_gateway::job::Source;
fn main() {
    let a: Vec<u64> = std::env::args()
        .skip(1)
        .filter_map(|s| s.parse().ok())
        .collect();
    let (seed, upto, until) = (a[0], a[1] as usize, a[2]);
    let mut s = hans_dst::Scenario::new(seed);
    for n in 0..upto {
        if let Err(f) = s.step(n) {
            println!("{}", f.what);
            break;
        }
    }
    let w = &mut s.world;
    while w.now().as_millis() < until {
        w.turn(Instant::from_millis(until));
        let ph = w.model(|m| m.handshake(Source::Raw).map(|h| h.phase));
        println!(
            "{:>9.3} fsm {} motion {:?} paused {} ch1 {:?}",
            w.now().as_micros() as f64 / 1000.0,
            w.robot.model.fsm,
            w.robot.model.motion_start().map(|t| t.as_millis()),
            w.robot.model.paused(),
            ph
        );
    }
}
