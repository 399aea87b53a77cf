//! The MQTT side of the end-to-end tests and the fleet benchmark: Debian's
//! Mosquitto on 127.0.0.1 (killed when dropped) and the Sparkplug B payload
//! as an independent consumer decodes it (prost, from the specification's
//! field numbers; not the gateway's encoder).

use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A Sparkplug B payload (the fields the tests read).
#[derive(Clone, PartialEq, prost::Message)]
pub struct Payload {
    /// ms since 1970 UTC, at publication.
    #[prost(uint64, optional, tag = "1")]
    pub timestamp: Option<u64>,
    /// The metrics.
    #[prost(message, repeated, tag = "2")]
    pub metrics: Vec<Metric>,
    /// 0-255; absent in NDEATH and commands.
    #[prost(uint64, optional, tag = "3")]
    pub seq: Option<u64>,
}

/// A metric of a [`Payload`] (the value fields the gateway uses).
#[derive(Clone, PartialEq, prost::Message)]
pub struct Metric {
    /// Its name.
    #[prost(string, optional, tag = "1")]
    pub name: Option<String>,
    /// When it was read.
    #[prost(uint64, optional, tag = "3")]
    pub timestamp: Option<u64>,
    /// Its datatype (Sparkplug's numbers).
    #[prost(uint32, optional, tag = "4")]
    pub datatype: Option<u32>,
    /// No value.
    #[prost(bool, optional, tag = "7")]
    pub is_null: Option<bool>,
    /// Int8-32 and UInt8-32 values.
    #[prost(uint32, optional, tag = "10")]
    pub int: Option<u32>,
    /// Int64 and UInt64 values.
    #[prost(uint64, optional, tag = "11")]
    pub long: Option<u64>,
    /// Float values.
    #[prost(float, optional, tag = "12")]
    pub float: Option<f32>,
    /// Boolean values.
    #[prost(bool, optional, tag = "14")]
    pub boolean: Option<bool>,
    /// String values.
    #[prost(string, optional, tag = "15")]
    pub string: Option<String>,
}

/// The broker, killed (and its directory removed) when dropped.
pub struct Mosquitto {
    child: Child,
    /// Its port on 127.0.0.1.
    pub port: u16,
    dir: PathBuf,
}

/// A free port on 127.0.0.1 (free when asked).
pub fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port on 127.0.0.1")
}

impl Mosquitto {
    /// Debian's mosquitto on 127.0.0.1 at `port` (a free one if `None`),
    /// anonymous, without persistence, `extra` appended to its
    /// configuration; waits (at most 10 s) until it listens.
    pub fn start(port: Option<u16>, extra: &str) -> Mosquitto {
        let bin = ["/usr/sbin/mosquitto", "/usr/bin/mosquitto"]
            .into_iter()
            .find(|p| Path::new(p).exists())
            .expect("mosquitto is not installed: `bash scripts/setup.sh` installs it");
        let port = port.unwrap_or_else(free_port);
        let dir = std::env::temp_dir().join(format!("hans-e2e-mqtt-{}-{port}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("a directory for the broker");
        let conf = dir.join("mosquitto.conf");
        std::fs::write(
            &conf,
            format!("listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\n{extra}"),
        )
        .expect("the broker's configuration");
        let child = Command::new(bin)
            .arg("-c")
            .arg(&conf)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("start mosquitto");
        let broker = Mosquitto { child, port, dir };
        let start = Instant::now();
        while TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "mosquitto did not start"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        broker
    }
}

impl Drop for Mosquitto {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}
