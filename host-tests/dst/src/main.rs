//! `hans-dst`: long simulation runs.
//!
//! ```text
//! hans-dst --seeds 0..100000 --steps 200 --threads 2    # a long run
//! hans-dst --seed 4711 --steps 200                      # replay one seed, with its trace
//! hans-dst --seconds 60                                 # as many seeds as fit in a minute
//! ```
//!
//! Prints the scenarios run, the PLC commands fired, the outcomes and the
//! rate; exits 1 on the first broken invariant, with its seed, step and
//! trace (it replays exactly).

use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use clap::Parser;

/// Deterministic simulation of the gateway: seeded PLCs and a faulty robot
/// in virtual time, invariants checked after every step.
#[derive(Parser)]
#[command(version)]
struct Args {
    /// Seeds to run, `A..B` (B excluded).
    #[arg(long, default_value = "0..1000")]
    seeds: String,
    /// One seed (replay).
    #[arg(long, conflicts_with = "seeds")]
    seed: Option<u64>,
    /// PLC actions per scenario.
    #[arg(long, default_value_t = 200)]
    steps: usize,
    /// Worker threads.
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Stop starting new seeds after this many seconds.
    #[arg(long)]
    seconds: Option<f64>,
    /// Print a progress line every N scenarios.
    #[arg(long, default_value_t = 1000)]
    every: u64,
}

fn range(s: &str) -> Option<(u64, u64)> {
    let (a, b) = s.split_once("..")?;
    Some((a.parse().ok()?, b.parse().ok()?))
}

fn main() -> ExitCode {
    let args = Args::parse();
    let (from, to) = match args.seed {
        Some(s) => (s, s + 1),
        None => match range(&args.seeds) {
            Some(r) => r,
            None => {
                eprintln!("hans-dst: --seeds wants A..B, got {:?}", args.seeds);
                return ExitCode::from(2);
            }
        },
    };
    let next = Arc::new(AtomicU64::new(from));
    let stop = Arc::new(AtomicBool::new(false));
    let total = Arc::new(Mutex::new(hans_dst::Stats::default()));
    let failure = Arc::new(Mutex::new(None::<hans_dst::Failure>));
    let start = Instant::now();
    let threads: Vec<_> = (0..args.threads.max(1))
        .map(|_| {
            let (next, stop, total, failure) =
                (next.clone(), stop.clone(), total.clone(), failure.clone());
            let (steps, seconds, every) = (args.steps, args.seconds, args.every);
            std::thread::spawn(move || loop {
                if stop.load(Ordering::Relaxed) {
                    return;
                }
                if seconds.is_some_and(|s| start.elapsed().as_secs_f64() >= s) {
                    return;
                }
                let seed = next.fetch_add(1, Ordering::Relaxed);
                if seed >= to {
                    return;
                }
                match hans_dst::run(seed, steps) {
                    Ok(s) => {
                        let mut t = total.lock().expect("stats");
                        t.add(&s);
                        if t.scenarios % every == 0 {
                            println!("{}", hans_dst::summary(&t, start.elapsed().as_secs_f64()));
                        }
                    }
                    Err(f) => {
                        stop.store(true, Ordering::Relaxed);
                        let mut slot = failure.lock().expect("failure");
                        if slot.as_ref().is_none_or(|g| f.seed < g.seed) {
                            *slot = Some(f);
                        }
                        return;
                    }
                }
            })
        })
        .collect();
    for t in threads {
        let _ = t.join();
    }
    let t = *total.lock().expect("stats");
    println!("{}", hans_dst::summary(&t, start.elapsed().as_secs_f64()));
    let last = next.load(Ordering::Relaxed).min(to);
    let failed = failure.lock().expect("failure").take();
    if failed.is_none() {
        println!(
            "seeds {from}..{last} (steps {}), zero invariant violations",
            args.steps
        );
    }
    if let Some(f) = failed {
        eprintln!("INVARIANT BROKEN\n{f}");
        eprintln!("replay: hans-dst --seed {} --steps {}", f.seed, args.steps);
        return ExitCode::from(1);
    }
    ExitCode::SUCCESS
}
