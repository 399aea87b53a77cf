//! The `hans-sim` program: prints one line per listener with the bound
//! address, serves on it, and applies `--fault` rules.

mod support;

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::Duration;

use support::Client;

/// Stops the program we started, also when an assertion fails.
struct KillOnDrop(std::process::Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[tokio::test]
async fn the_program_reports_its_ports_and_serves() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_hans-sim"))
        .args(["--command-port", "0", "--datasheet-ports", "0,0", "--ready"])
        .args(["--fast-port", "0"])
        .args(["--fault", "fail=20018:busy@SetBoxDO*1"])
        .stdout(Stdio::piped())
        .spawn()
        .expect("start hans-sim");
    let stdout = child.stdout.take().unwrap();
    let _child = KillOnDrop(child);
    let lines = tokio::task::spawn_blocking(move || {
        BufReader::new(stdout)
            .lines()
            .take(5)
            .map(|l| l.unwrap())
            .collect::<Vec<_>>()
    });
    let lines = tokio::time::timeout(Duration::from_secs(20), lines).await;
    {
        let lines = lines.expect("ready lines within 20 s").unwrap();
        assert!(
            lines[0].starts_with("hans-sim: command port listening on 127.0.0.1:"),
            "{lines:?}"
        );
        assert!(lines[1].contains("datasheet port (20 Hz)") && lines[2].contains("(10 Hz)"));
        assert!(
            lines[3].starts_with("hans-sim: fast command port listening on 127.0.0.1:"),
            "{lines:?}"
        );
        assert_eq!(lines[4], "hans-sim: protocol level HR6.6.1");
        let fast = lines[3].rsplit(' ').next().unwrap().parse().unwrap();
        let mut f = Client::connect(fast).await;
        assert_eq!(f.call("ReadCurFSM,0,;").await, "ReadCurFSM,OK,33,;");
        let addr = lines[0].rsplit(' ').next().unwrap().parse().unwrap();
        let mut c = Client::connect(addr).await;
        assert_eq!(c.call("ReadCurFSM,0,;").await, "ReadCurFSM,OK,33,;");
        assert_eq!(c.call("SetBoxDO,1,1,;").await, "SetBoxDO,Fail,20018,busy,;");
        assert_eq!(c.call("SetBoxDO,1,1,;").await, "SetBoxDO,OK,;");
    }
}
