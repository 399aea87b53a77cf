//! The rig the firmware test files use: a firmware under QEMU, the robot
//! simulator on 127.0.0.1 (in this process, on a tokio runtime of its own),
//! and what ending them leaves to check.
//!
//! Each test file includes this module (`mod common;`) and uses part of it,
//! hence the `dead_code` allowance.
#![allow(dead_code)]

use std::process::ExitStatus;
use std::time::{Duration, Instant};

use hans_sim::{Config as SimConfig, Sim, Timing};
use qemu_tests::{check_stack_budget, connect_retry, firmware_elf, request_line, Plc, Ports, Qemu};

/// The bound of every wait for the firmware (QEMU under load is slow).
pub const STEP: Duration = Duration::from_secs(60);

/// QEMU with one firmware, the simulator, and a tokio runtime for it.
pub struct Rig {
    /// The simulator's runtime.
    pub rt: tokio::runtime::Runtime,
    /// The simulator (taken by tests that restart it).
    pub sim: Option<Sim>,
    /// The firmware under QEMU.
    pub qemu: Qemu,
    /// The test's name, in logs and file names.
    pub name: &'static str,
    /// The firmware (a binary of the mps2-an386 board): its stack budget
    /// is checked at the end ([`Rig::check_stack`]).
    pub firmware: &'static str,
}

impl Rig {
    /// Starts the simulator and `firmware` (a binary of the mps2-an386
    /// board) with `args` as its command line (`dhcp`: DHCP as the factory
    /// network setting).
    pub fn start(firmware: &'static str, name: &'static str, args: &str) -> Rig {
        Rig::start_with_env(firmware, name, args, &[])
    }

    /// As [`Rig::start`], with more variables for `scripts/qemu-run.sh`
    /// (`MQTT_PORT`: the broker the firmware publishes to).
    pub fn start_with_env(
        firmware: &'static str,
        name: &'static str,
        args: &str,
        env: &[(&str, String)],
    ) -> Rig {
        let ports = Ports::pick();
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .enable_all()
            .build()
            .expect("tokio runtime");
        let sim = rt.block_on(start_sim(ports.sim));
        let qemu = Qemu::start_with_env(
            name,
            &firmware_elf(firmware),
            ports,
            Duration::from_secs(300),
            args,
            env,
        )
        .expect("start QEMU");
        Rig {
            rt,
            sim: Some(sim),
            qemu,
            name,
            firmware,
        }
    }

    /// The simulator, which must be running.
    pub fn sim(&self) -> &Sim {
        self.sim.as_ref().expect("simulator running")
    }

    /// A Modbus session that has answered one request (see [`modbus_at`]).
    pub fn modbus(&self) -> Plc {
        modbus_at(self.qemu.ports.modbus, self.name)
    }

    /// Ends the firmware through the diagnostics port (the stack report is
    /// printed), prints its log, expects exit status 0. Returns the log
    /// (text if `defmt-print` is installed).
    pub fn exit(mut self) -> String {
        let report = request_line(self.qemu.ports.admin, "exit\n", Duration::from_secs(30))
            .expect("diagnostics report");
        println!("{}: {}", self.name, report.trim());
        let (status, log) = self.wait_end();
        assert!(report.starts_with("stack_used="), "report: {report}");
        assert_eq!(status.and_then(|s| s.code()), Some(0), "exit status");
        self.check_stack(&report);
        log
    }

    /// Fails the test if the stack high-water mark in the diagnostics
    /// `report` is over the firmware's budget (`qemu_tests::STACK_BUDGETS`).
    pub fn check_stack(&self, report: &str) {
        if let Err(e) = check_stack_budget(self.name, self.firmware, report) {
            panic!("{e}");
        }
    }

    /// Waits (30 s at most) for QEMU to end after the firmware was told to,
    /// prints the firmware's log and stops the simulator. Returns QEMU's
    /// exit status and the log (text if `defmt-print` is installed).
    pub fn wait_end(&mut self) -> (Option<ExitStatus>, String) {
        let status = self.qemu.process().wait(Duration::from_secs(30));
        let log = self.qemu.log_text();
        println!("--- {} firmware log ---\n{log}", self.name);
        if let Some(sim) = self.sim.take() {
            self.rt.block_on(sim.shutdown());
        }
        (status, log)
    }
}

impl Drop for Rig {
    fn drop(&mut self) {
        if std::thread::panicking() {
            println!(
                "--- {} firmware log ---\n{}",
                self.name,
                self.qemu.log_text()
            );
            println!(
                "--- {} QEMU stderr (running: {}) ---\n{}",
                self.name,
                self.qemu.process().running(),
                self.qemu.stderr_text()
            );
            if let Some(sim) = self.sim.as_ref() {
                println!("--- simulator received ---\n{:?}", sim.received());
            }
        }
    }
}

/// A Modbus session with the firmware on host port `port` that has
/// answered one request (the guest may not be listening yet, or all its
/// sessions may be busy: then QEMU accepts and closes at once, and we try
/// again, for [`STEP`] at most). `name` names the test in the failure.
pub fn modbus_at(port: u16, name: &str) -> Plc {
    let start = Instant::now();
    loop {
        let stream = connect_retry(port, STEP).expect("connect to :502");
        let mut client = Plc::new(stream, Duration::from_secs(5)).expect("Modbus client");
        if let Ok(Ok(_)) = client.read_holding_registers(0, 1) {
            return client;
        }
        assert!(
            start.elapsed() < STEP,
            "{name}: no Modbus session within {STEP:?}"
        );
        std::thread::sleep(Duration::from_millis(300));
    }
}

/// Polls `f` every 100 ms until it returns `Some`, for at most `limit`.
pub fn wait_for<T>(what: &str, limit: Duration, mut f: impl FnMut() -> Option<T>) -> T {
    let start = Instant::now();
    loop {
        if let Some(v) = f() {
            return v;
        }
        assert!(
            start.elapsed() < limit,
            "timed out after {limit:?} waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The simulator on `port`, ready at once (no bring-up delays), without
/// DataSheet ports. The port was free a moment ago, or the previous
/// simulator just closed it: retry briefly.
pub async fn start_sim(port: u16) -> Sim {
    let config = SimConfig {
        command_port: port,
        datasheet_ports: Vec::new(),
        timing: Timing::instant(),
        ..SimConfig::default()
    };
    let start = Instant::now();
    loop {
        match Sim::start(config.clone()).await {
            Ok(sim) => return sim,
            Err(e) if start.elapsed() < Duration::from_secs(10) => {
                eprintln!("simulator: {e}; retrying");
                tokio::time::sleep(Duration::from_millis(200)).await;
            }
            Err(e) => panic!("simulator cannot listen on {port}: {e}"),
        }
    }
}
