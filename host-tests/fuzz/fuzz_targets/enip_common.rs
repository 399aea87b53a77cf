//! Shared by the hans-enip targets: a device with an input, an output and
//! a configuration assembly and the three kinds of class 1 connection, an
//! application over plain buffers, and the check that a reply is a
//! well-formed encapsulation packet answering its request.
#![allow(dead_code)]

use core::net::Ipv4Addr;

use hans_enip::wire::cip::{GeneralStatus, ResponseHeader};
use hans_enip::wire::cpf::{Cpf, ItemType};
use hans_enip::wire::encap::{Command, Header, Status, HEADER_LEN};
use hans_enip::wire::session::SendDataRepr;
use hans_enip::*;

pub static ASSEMBLIES: [Assembly<'static>; 3] = [
    Assembly { instance: 100, kind: AssemblyKind::Input, size: 8, name: "in" },
    Assembly { instance: 150, kind: AssemblyKind::Output, size: 8, name: "out" },
    Assembly { instance: 151, kind: AssemblyKind::Config, size: 4, name: "cfg" },
];
pub static CONNECTIONS: [IoConnection<'static>; 3] = [
    IoConnection { kind: ConnectionKind::ExclusiveOwner, o_to_t: 150, t_to_o: 100, config: 151, name: "eo" },
    IoConnection { kind: ConnectionKind::InputOnly, o_to_t: 198, t_to_o: 100, config: 151, name: "io" },
    IoConnection { kind: ConnectionKind::ListenOnly, o_to_t: 199, t_to_o: 100, config: 151, name: "lo" },
];
pub static DEVICE: Device<'static> = Device { assemblies: &ASSEMBLIES, connections: &CONNECTIONS };

pub const SESSIONS: usize = 2;
pub const CONNS: usize = 3;
pub type FuzzAdapter = Adapter<'static, SESSIONS, CONNS>;

pub fn adapter() -> FuzzAdapter {
    Adapter::new(&DEVICE, Config::default())
}

#[derive(Default)]
pub struct App {
    pub out: [u8; 8],
    pub cfg: [u8; 4],
    pub opened: usize,
    pub closed: usize,
}

impl Application for App {
    fn identity(&self) -> Identity<'_> {
        Identity {
            vendor_id: 0xFFFE,
            device_type: 0x0C,
            product_code: 1,
            revision: Revision { major: 1, minor: 1 },
            status: 0,
            serial: 1,
            product_name: "fuzz",
        }
    }
    fn tcp_ip(&self) -> TcpIpInfo<'_> {
        TcpIpInfo {
            status: 1,
            config_capability: 0,
            config_control: 0,
            ip: Ipv4Addr::new(127, 0, 0, 1),
            netmask: Ipv4Addr::new(255, 0, 0, 0),
            gateway: Ipv4Addr::UNSPECIFIED,
            dns1: Ipv4Addr::UNSPECIFIED,
            dns2: Ipv4Addr::UNSPECIFIED,
            domain: "d",
            host_name: "h",
        }
    }
    fn ethernet_link(&self) -> EthernetLinkInfo {
        EthernetLinkInfo { speed_mbps: 100, flags: 1, mac: [2, 0, 0, 0, 0, 1] }
    }
    fn read_assembly(&mut self, instance: u16, buf: &mut [u8]) {
        match instance {
            100 | 150 => buf.copy_from_slice(&self.out),
            151 => buf.copy_from_slice(&self.cfg),
            other => panic!("read of assembly {other}"),
        }
    }
    fn write_assembly(&mut self, instance: u16, data: &[u8], _: WriteOrigin) -> Result<(), GeneralStatus> {
        match instance {
            150 => self.out.copy_from_slice(data),
            151 => self.cfg.copy_from_slice(data),
            other => panic!("write of assembly {other}"),
        }
        Ok(())
    }
    fn event(&mut self, e: Event) {
        match e {
            Event::Opened { .. } => self.opened += 1,
            Event::Closed { .. } => self.closed += 1,
            Event::RunIdle { .. } => {}
        }
    }
}

/// A reply must be an encapsulation packet whose length field is its
/// length, answering `request` (same command and context), and a
/// successful SendRRData reply must carry a Message Router response.
pub fn check_reply(request: &Header, reply: &[u8]) {
    let h = Header::parse(reply).expect("a reply has a header");
    assert_eq!(usize::from(h.length), reply.len() - HEADER_LEN, "length field");
    assert_eq!(h.command, request.command, "command echoed");
    assert_eq!(h.context, request.context, "context echoed");
    assert_eq!(h.options, 0);
    assert!(!matches!(h.status, Status::Unknown(_)), "a status of the specification: {:?}", h.status);
    let data = &reply[HEADER_LEN..];
    if h.status != Status::Success {
        return;
    }
    match h.command {
        Command::SendRrData | Command::SendUnitData => {
            let sd = SendDataRepr::parse(data).expect("prefix");
            let cpf = Cpf::parse(sd.cpf).expect("CPF");
            assert_eq!(cpf.items().len(), 2);
            let item = cpf.get(1).expect("data item");
            let mr = if h.command == Command::SendRrData {
                assert_eq!(cpf.get(0).map(|i| i.kind), Some(ItemType::NullAddress));
                assert_eq!(item.kind, ItemType::UnconnectedData);
                item.data
            } else {
                assert_eq!(cpf.get(0).map(|i| i.kind), Some(ItemType::ConnectedAddress));
                assert_eq!(item.kind, ItemType::ConnectedData);
                &item.data[2..]
            };
            ResponseHeader::parse(mr).expect("a Message Router response");
        }
        Command::ListIdentity | Command::ListServices | Command::ListInterfaces => {
            Cpf::parse(data).expect("CPF");
        }
        Command::RegisterSession => assert_eq!(data.len(), 4),
        other => panic!("a success reply to {other:?}"),
    }
}
