//! Common Packet Format items from arbitrary bytes: whatever parses writes
//! back to the same bytes (item lists, class 1 datagrams, Sockaddr Info,
//! ListServices items), and a CIP Identity item reads back the same after
//! writing. Never a panic.
#![no_main]

use hans_enip::wire::cpf::{Cpf, CpfWriter, ItemType, Sockaddr};
use hans_enip::wire::identity_item::{IdentityItem, ServicesItem, MAX_PRODUCT_NAME};
use hans_enip::wire::io::IoPacket;
use hans_enip::wire::Writer;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut buf = vec![0u8; data.len() + 64];
    if let Ok(cpf) = Cpf::parse(data) {
        let mut w = Writer::new(&mut buf);
        let mut c = CpfWriter::begin(&mut w).expect("room");
        for item in cpf.items() {
            c.item(&mut w, item.kind, item.data).expect("room");
            match item.kind {
                ItemType::SockaddrOT | ItemType::SockaddrTO => {
                    if let Ok(s) = Sockaddr::parse(item.data) {
                        let mut b = [0u8; 16];
                        s.emit(&mut Writer::new(&mut b)).expect("16 bytes");
                        // sin_zero is not kept: compare the first 8 bytes.
                        assert_eq!(&b[..8], &item.data[..8]);
                    }
                }
                ItemType::CipIdentity => {
                    if let Ok(id) = IdentityItem::parse(item.data) {
                        let mut b = vec![0u8; item.data.len() + 8];
                        let mut w2 = Writer::new(&mut b);
                        id.emit(&mut w2).expect("room");
                        let n = w2.len();
                        let back = IdentityItem::parse(&b[..n]).expect("reads back");
                        if id.identity.product_name.len() <= MAX_PRODUCT_NAME {
                            assert_eq!(back, id);
                        }
                    }
                }
                ItemType::ListServices => {
                    if let Ok(s) = ServicesItem::parse(item.data) {
                        let mut b = [0u8; 20];
                        s.emit(&mut Writer::new(&mut b)).expect("20 bytes");
                        assert_eq!(&b[..], item.data);
                    }
                }
                _ => {}
            }
        }
        let n = w.len();
        assert_eq!(&buf[..n], data, "an item list writes back to its bytes");
    }
    if let Ok(p) = IoPacket::parse(data) {
        let mut w = Writer::new(&mut buf);
        p.emit(&mut w).expect("room");
        let n = w.len();
        assert_eq!(&buf[..n], data, "a class 1 datagram writes back to its bytes");
    }
});
