//! The DataSheet client (chapter 5): deframe packets and decode their JSON.
#![no_std]
#![no_main]

use hans_codec::datasheet::{DataSheet, Deframer};
use hans_codec_footprint::{input, output, BUF};

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut rx = [0u8; BUF];
    let mut deframer = Deframer::<{ DataSheet::MAX_JSON_LEN }>::new();
    loop {
        let bytes = input(&mut rx).as_bytes();
        deframer.feed(bytes, |item| {
            if let Ok(payload) = item {
                let sheet = DataSheet::parse(payload);
                output(&sheet, sheet.is_ok() as u32);
            }
        });
    }
}
