//! The adapter as a board runs it: encapsulation on TCP (a framer), UDP
//! discovery, class 1 I/O and the clock, with 4 sessions and 4 connections.
//! Built with the feature `eds`, the EDS writer too.
#![no_std]
#![no_main]

use core::net::{Ipv4Addr, SocketAddrV4};

use hans_enip::wire::cip::GeneralStatus;
use hans_enip::*;
use hans_enip_footprint::{receive, send, word, BUF};

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}

static ASSEMBLIES: [Assembly<'static>; 2] = [
    Assembly {
        instance: 100,
        kind: AssemblyKind::Input,
        size: 64,
        name: "Robot to PLC",
    },
    Assembly {
        instance: 150,
        kind: AssemblyKind::Output,
        size: 64,
        name: "PLC to robot",
    },
];
static CONNECTIONS: [IoConnection<'static>; 2] = [
    IoConnection {
        kind: ConnectionKind::ExclusiveOwner,
        o_to_t: 150,
        t_to_o: 100,
        config: 1,
        name: "Owner",
    },
    IoConnection {
        kind: ConnectionKind::InputOnly,
        o_to_t: 198,
        t_to_o: 100,
        config: 1,
        name: "Input Only",
    },
];
static DEVICE: Device<'static> = Device {
    assemblies: &ASSEMBLIES,
    connections: &CONNECTIONS,
};

struct App {
    data: [u8; 64],
}

impl Application for App {
    fn identity(&self) -> Identity<'_> {
        Identity {
            vendor_id: 0xFFFE,
            device_type: 0x0C,
            product_code: 1,
            revision: Revision { major: 1, minor: 1 },
            status: 0,
            serial: word(),
            product_name: "Hans gateway",
        }
    }
    fn tcp_ip(&self) -> TcpIpInfo<'_> {
        TcpIpInfo {
            status: 1,
            config_capability: 4,
            config_control: 0,
            ip: Ipv4Addr::from(word()),
            netmask: Ipv4Addr::new(255, 255, 255, 0),
            gateway: Ipv4Addr::UNSPECIFIED,
            dns1: Ipv4Addr::UNSPECIFIED,
            dns2: Ipv4Addr::UNSPECIFIED,
            domain: "",
            host_name: "hans-gw",
        }
    }
    fn ethernet_link(&self) -> EthernetLinkInfo {
        EthernetLinkInfo {
            speed_mbps: 100,
            flags: 1,
            mac: [2, 0, 0, 0, 0, 1],
        }
    }
    fn read_assembly(&mut self, _instance: u16, buf: &mut [u8]) {
        let n = buf.len().min(self.data.len());
        buf[..n].copy_from_slice(&self.data[..n]);
    }
    fn write_assembly(
        &mut self,
        _instance: u16,
        data: &[u8],
        _: WriteOrigin,
    ) -> Result<(), GeneralStatus> {
        let n = data.len().min(self.data.len());
        self.data[..n].copy_from_slice(&data[..n]);
        Ok(())
    }
    fn event(&mut self, event: Event) {
        send(&[matches!(event, Event::Closed { .. }) as u8]);
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut adapter: Adapter<'_, 4, 4> = Adapter::new(
        &DEVICE,
        Config {
            seed: word(),
            ..Config::default()
        },
    );
    let mut app = App { data: [0; 64] };
    let mut framer = Framer::<BUF>::new();
    let mut rx = [0u8; BUF];
    let mut tx = [0u8; BUF];
    loop {
        let n = receive(&mut rx);
        let now = Instant::from_micros(u64::from(word()));
        let peer = SocketAddrV4::new(Ipv4Addr::from(word()), 2222);
        match word() % 3 {
            0 => {
                let mut rest = &rx[..n];
                while !rest.is_empty() {
                    let used = framer.push(rest);
                    rest = &rest[used..];
                    if let Some(frame) = framer.frame() {
                        match adapter.handle_tcp(
                            LinkId(word()),
                            *peer.ip(),
                            frame,
                            now,
                            &mut app,
                            &mut tx,
                        ) {
                            TcpAction::Reply(m) => send(&tx[..m]),
                            TcpAction::Close => adapter.tcp_closed(LinkId(0), now, &mut app),
                            TcpAction::None => {}
                        }
                    }
                }
            }
            1 => {
                if let Some(m) = adapter.handle_udp(&rx[..n], &mut app, &mut tx) {
                    send(&tx[..m]);
                }
            }
            _ => {
                let r = adapter.handle_io(peer, &rx[..n], now, &mut app);
                send(&[r as u8]);
            }
        }
        while let Some((_dest, m)) = adapter.poll(now, &mut app, &mut tx) {
            send(&tx[..m]);
        }
        #[cfg(feature = "eds")]
        {
            let identity = app.identity();
            let mut text = heapless::String::<4096>::new();
            if hans_enip::eds::write_eds(
                &mut text,
                &hans_enip::eds::EdsInfo::new(&identity, &DEVICE, "Hans"),
            )
            .is_ok()
            {
                send(text.as_bytes());
            }
        }
        send(&[adapter.poll_at().is_some() as u8]);
    }
}
