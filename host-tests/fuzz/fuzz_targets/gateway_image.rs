//! A stored configuration image as a damaged flash sector or file gives
//! it: the decoder refuses it whole or gives a configuration whose every
//! setting is in range (and which encodes to an image that decodes to the
//! same); a gateway started on it ([`Gateway::load`], what `Gateway::run`
//! does first) runs with exactly that configuration, accounts and trigger
//! table, or with the defaults, and its registers show a configuration in
//! range. Never a panic.
//!
//! Each input is tried twice: as it is, and with its last four bytes made
//! the CRC of the rest, so that mutations get past the CRC to the layout
//! and the values (the CRC check itself is the first run's).
#![no_main]

use core::future::Future;
use core::pin::pin;
use core::task::{Context, Waker};

use hans_gateway::config::Config;
use hans_gateway::registers as r;
use hans_gateway::registers::config::{decode as from_registers, Words, CONFIG_WORDS};
use hans_gateway::state::{Text, Triggers};
use hans_gateway::crc::crc32;
use hans_gateway::storage::image::{decode, encode, Entries};
use hans_gateway::storage::IMAGE_LEN;
use hans_gateway::testkit::clock::VirtualClock;
use hans_gateway::testkit::world::MemStorage;
use hans_gateway::{Clock, Gateway, Options};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    check(data);
    if let Some(n) = data.len().checked_sub(4) {
        let mut fixed = data.to_vec();
        let crc = crc32(&fixed[..n]).to_le_bytes();
        if fixed[n..] != crc {
            fixed[n..].copy_from_slice(&crc);
            check(&fixed);
        }
    }
});

fn check(data: &[u8]) {
    let mut entries: Entries = [Text::EMPTY; 16];
    let defaults = Config::default();
    let decoded = decode(data, &defaults, &mut entries);
    if let Ok(stored) = decoded {
        assert_eq!(stored.config.check(), Ok(()));
        let mut image = [0u8; IMAGE_LEN];
        let n = encode(&stored, &entries, &mut image).expect("room");
        let mut again: Entries = [Text::EMPTY; 16];
        assert_eq!(decode(&image[..n], &defaults, &mut again), Ok(stored));
        assert_eq!(again, entries);
    }
    // A gateway started on it.
    let mut storage = MemStorage::default();
    *storage.data.borrow_mut() = data.to_vec();
    let clock = VirtualClock::new();
    let gw = Gateway::new(Options {
        defaults,
        ..Options::default()
    });
    let load = pin!(gw.load(&mut storage, &clock));
    assert!(
        load.poll(&mut Context::from_waker(Waker::noop()))
            .is_ready(),
        "loading from memory waits"
    );
    let (active, accounts, loaded) = gw
        .hub()
        .with(|m| (m.config.active, m.access.accounts, m.triggers.entries));
    match decoded {
        Ok(stored) => {
            assert_eq!(active, stored.config, "not the stored configuration");
            assert_eq!(accounts, stored.accounts);
            assert!(
                accounts.is_empty() || accounts.admin_exists(),
                "accounts without an administrator loaded"
            );
            assert_eq!(loaded, entries);
        }
        Err(_) => {
            assert_eq!(active, defaults, "a refused image, not the defaults");
            assert!(accounts.is_empty(), "accounts of a refused image");
            assert_eq!(loaded, Triggers::default().entries);
        }
    }
    // Its registers show a configuration in range.
    let now = clock.now();
    let mut words: Words = [0; CONFIG_WORDS];
    let mut a = [0u16; r::CONFIG_LEN as usize];
    let mut b = [0u16; r::NET_LEN as usize];
    gw.hub()
        .with(|m| r::view::read_into(m, r::CONFIG_ROBOT_IP, &mut a, now))
        .expect("the configuration reads");
    gw.hub()
        .with(|m| r::view::read_into(m, r::NET_IP, &mut b, now))
        .expect("the network settings read");
    for (slot, v) in words.iter_mut().zip(a.into_iter().chain(b)) {
        *slot = v;
    }
    assert_eq!(from_registers(&words, &active), Ok(active));
}
