//! A bounded simulation run inside `cargo test`: a fixed range of seeds,
//! every invariant checked after every step. The long runs are `hans-dst`'s
//! (see the README).

#[test]
fn seeds_0_to_119_keep_every_invariant() {
    let mut total = hans_dst::Stats::default();
    let start = std::time::Instant::now();
    for seed in 0..120 {
        match hans_dst::run(seed, 200) {
            Ok(s) => total.add(&s),
            Err(f) => {
                panic!("{f}\nreplay: cargo run --release -p hans-dst -- --seed {seed} --steps 200")
            }
        }
    }
    println!(
        "{}",
        hans_dst::summary(&total, start.elapsed().as_secs_f64())
    );
    assert!(total.commands > 120 * 40, "too few commands: {total:?}");
    assert!(
        total.done > 0 && total.errors > 0 && total.aborted > 0,
        "{total:?}"
    );
}

#[test]
fn a_seed_replays_exactly() {
    let a = hans_dst::run(7, 80).expect("seed 7");
    let b = hans_dst::run(7, 80).expect("seed 7 again");
    assert_eq!(a, b);
}
