//! A stored configuration image as a damaged flash sector or file gives
//! it: the decoder refuses it whole or gives a configuration whose every
//! setting is in range (and which encodes back to the same bytes); a gateway
//! started on it runs with it or with the defaults, and never panics.
#![no_main]

use embassy_time::Duration;
use hans_gateway::config::{Config, FIELDS};
use hans_gateway::registers as r;
use hans_gateway::state::Text;
use hans_gateway::storage::image::{decode, encode, Entries};
use hans_gateway::storage::IMAGE_LEN;
use hans_gateway::testkit::world::{MemStorage, World, WorldConfig};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut entries: Entries = [Text::EMPTY; 16];
    if let Ok(c) = decode(data, &mut entries) {
        let words = c.to_words();
        for f in FIELDS {
            assert!(f.domain.contains(words[usize::from(f.addr - r::CONFIG_ROBOT_IP)]));
        }
        let mut back = [0u8; IMAGE_LEN];
        encode(&c, &entries, &mut back).expect("room");
        assert_eq!(&back[..], data);
    }
    let storage = MemStorage::default();
    *storage.data.borrow_mut() = data.to_vec();
    let mut w = World::new(WorldConfig {
        storage,
        config: Config::default(),
        ..WorldConfig::default()
    });
    w.run_for(Duration::from_millis(50));
    let cfg = w.read(r::CONFIG_ROBOT_IP, r::CONFIG_LEN).expect("the configuration reads");
    assert!(Config::from_words(&cfg.try_into().expect("16 words")).is_ok());
});
