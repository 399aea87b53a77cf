//! A stored configuration image as a damaged flash sector or file gives
//! it: the decoder refuses it whole or gives a configuration whose every
//! setting is in range (and which encodes to an image that decodes to the
//! same); a gateway started on it runs with it or with the defaults, and
//! never panics.
#![no_main]

use embassy_time::Duration;
use hans_gateway::config::{Config, Words, CONFIG_WORDS};
use hans_gateway::registers as r;
use hans_gateway::state::Text;
use hans_gateway::storage::image::{decode, encode, Entries};
use hans_gateway::storage::IMAGE_LEN;
use hans_gateway::testkit::world::{MemStorage, World, WorldConfig};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut entries: Entries = [Text::EMPTY; 16];
    let defaults = Config::default();
    if let Ok(stored) = decode(data, &defaults, &mut entries) {
        assert_eq!(Config::from_words(&stored.config.to_words()), Ok(stored.config));
        let mut image = [0u8; IMAGE_LEN];
        encode(&stored, &entries, &mut image).expect("room");
        let mut again: Entries = [Text::EMPTY; 16];
        assert_eq!(decode(&image, &defaults, &mut again), Ok(stored));
        assert_eq!(again, entries);
    }
    let storage = MemStorage::default();
    *storage.data.borrow_mut() = data.to_vec();
    let mut w = World::new(WorldConfig {
        storage,
        config: Config::default(),
        ..WorldConfig::default()
    });
    w.run_for(Duration::from_millis(50));
    let mut words: Words = [0; CONFIG_WORDS];
    let a = w.read(r::CONFIG_ROBOT_IP, r::CONFIG_LEN).expect("the configuration reads");
    let b = w.read(r::NET_IP, r::NET_LEN).expect("the network settings read");
    for (slot, v) in words.iter_mut().zip(a.into_iter().chain(b)) {
        *slot = v;
    }
    assert!(Config::from_words(&words).is_ok());
});
