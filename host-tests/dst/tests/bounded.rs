//! A bounded simulation run inside `cargo test`: a fixed range of seeds,
//! every invariant checked after every step. The long runs are `hans-dst`'s
//! (see the README).

/// 114 seeds: as long as the 120 seeds it ran before a third of them had
/// an EtherNet/IP PLC (its datagrams and checks cost ~5 %).
#[test]
fn seeds_0_to_113_keep_every_invariant() {
    let mut total = hans_dst::Stats::default();
    let start = std::time::Instant::now();
    for seed in 0..114 {
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
    assert!(total.commands > 114 * 40, "too few commands: {total:?}");
    assert!(
        total.done > 0 && total.errors > 0 && total.aborted > 0,
        "{total:?}"
    );
    // The EtherNet/IP PLC (a third of the seeds) fired commands through
    // its assemblies, and lost its connection during watched motions.
    assert!(
        total.enip_commands > 100 && total.enip_lost > 0,
        "{total:?}"
    );
}

#[test]
fn a_seed_replays_exactly() {
    let a = hans_dst::run(7, 80).expect("seed 7");
    let b = hans_dst::run(7, 80).expect("seed 7 again");
    assert_eq!(a, b);
}

/// MQTT never disturbs the cell: with the telemetry on, the PLCs are
/// answered the same, at the same instants, whether the broker takes
/// everything, refuses connections, never answers, drops each connection
/// after a while, or refuses the password, as with no telemetry at all;
/// and every invariant holds in each run.
#[test]
fn the_plc_sees_the_same_gateway_whatever_the_broker_does() {
    use hans_gateway::testkit::broker::BrokerMode;
    use std::time::Duration as StdDuration;

    let modes = [
        Some(BrokerMode::Up),
        Some(BrokerMode::Refusing),
        Some(BrokerMode::Blackhole),
        Some(BrokerMode::Flapping(embassy_time::Duration::from_millis(
            700,
        ))),
        Some(BrokerMode::BadPassword),
    ];
    let start = std::time::Instant::now();
    let mut seeds = 0;
    for seed in 1000..1024u64 {
        let (reference, trace) =
            hans_dst::run_with_broker(seed, 120, None).unwrap_or_else(|f| panic!("{f}"));
        for mode in modes {
            let (stats, t) = hans_dst::run_with_broker(seed, 120, mode)
                .unwrap_or_else(|f| panic!("broker {mode:?}: {f}"));
            assert_eq!(
                stats, reference,
                "seed {seed}, broker {mode:?}: the same commands and outcomes"
            );
            assert_eq!(
                t, trace,
                "seed {seed}, broker {mode:?}: the same answers at the same instants"
            );
        }
        seeds += 1;
        // Bounded in time (a slow machine checks fewer seeds, never none).
        if start.elapsed() > StdDuration::from_secs(40) {
            break;
        }
    }
    println!(
        "{seeds} seeds x {} broker modes: the PLC's view unchanged",
        modes.len()
    );
}
