//! Replays seeds and prints the error codes they saw (for tuning the
//! generator): `cargo run --release -p hans-dst --example codes -- 0 100`.
fn main() {
    let from: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let to: u64 = std::env::args()
        .nth(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(50);
    let mut codes = std::collections::BTreeMap::<i32, u64>::new();
    for seed in from..to {
        let mut s = hans_dst::Scenario::new(seed);
        for n in 0..200 {
            if let Err(f) = s.step(n) {
                println!("{f}");
                return;
            }
        }
        for (c, n) in &s.checker.codes {
            *codes.entry(*c).or_default() += n;
        }
    }
    println!("{codes:?}");
}
