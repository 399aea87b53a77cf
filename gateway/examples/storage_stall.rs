//! How long a configuration save keeps the CPU between two awaits (the
//! longest time it stops the executor), measured on the host: saves of the
//! full image through `FlashStorage` (sequential-storage) over a NOR flash
//! model whose erases and programs take time, as bank 2 of the NUCLEO's
//! flash does (they await, the CPU runs on). Every poll of the save future
//! is timed; the longest is the stall.
//!
//! `cargo run --release -p hans-gateway --example storage_stall --features flash,testkit`
//!
//! On the board the same code runs between the same awaits; the board's
//! driver adds its own steps (one 16 KiB erase started, or up to 64 words
//! programmed, ~1 ms, between two yields).

use core::future::Future;
use core::pin::pin;
use core::task::{Context, Poll, Waker};
use std::time::{Duration, Instant};

use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use hans_gateway::storage::flash::FlashStorage;
use hans_gateway::storage::{ConfigStore, Image, StorageError, IMAGE_LEN};

const SECTOR: usize = 16 * 1024;

/// NOR flash in RAM whose erase and program operations yield once (the
/// board's flash is busy then, and the executor runs other tasks).
struct Nor(Vec<u8>);

#[derive(Debug)]
struct E;
impl NorFlashError for E {
    fn kind(&self) -> NorFlashErrorKind {
        NorFlashErrorKind::Other
    }
}
impl ErrorType for Nor {
    type Error = E;
}

struct YieldOnce(bool);
impl Future for YieldOnce {
    type Output = ();
    fn poll(mut self: core::pin::Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<()> {
        if self.0 {
            Poll::Ready(())
        } else {
            self.0 = true;
            cx.waker().wake_by_ref();
            Poll::Pending
        }
    }
}

impl ReadNorFlash for Nor {
    const READ_SIZE: usize = 1;
    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), E> {
        let o = offset as usize;
        bytes.copy_from_slice(&self.0[o..o + bytes.len()]);
        Ok(())
    }
    fn capacity(&self) -> usize {
        self.0.len()
    }
}

impl NorFlash for Nor {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = SECTOR;
    async fn erase(&mut self, from: u32, to: u32) -> Result<(), E> {
        YieldOnce(false).await;
        self.0[from as usize..to as usize].fill(0xFF);
        Ok(())
    }
    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), E> {
        // The board yields every 64 words while programming.
        for (i, chunk) in bytes.chunks(256).enumerate() {
            let o = offset as usize + 256 * i;
            self.0[o..o + chunk.len()].copy_from_slice(chunk);
            YieldOnce(false).await;
        }
        Ok(())
    }
}

struct Pattern(u8);
impl Image for Pattern {
    fn write(&self, out: &mut [u8]) -> Result<usize, StorageError> {
        let dst = out.get_mut(..IMAGE_LEN).ok_or(StorageError::TooLarge)?;
        for (i, b) in dst.iter_mut().enumerate() {
            *b = self.0.wrapping_add(i as u8);
        }
        Ok(IMAGE_LEN)
    }
}

/// Polls `fut` to its end, timing every poll; (result, longest poll, polls).
fn timed<F: Future>(fut: F) -> (F::Output, Duration, u32) {
    let mut fut = pin!(fut);
    let mut cx = Context::from_waker(Waker::noop());
    let (mut longest, mut polls) = (Duration::ZERO, 0);
    loop {
        let t = Instant::now();
        let p = fut.as_mut().poll(&mut cx);
        longest = longest.max(t.elapsed());
        polls += 1;
        if let Poll::Ready(v) = p {
            return (v, longest, polls);
        }
    }
}

fn main() {
    let mut storage =
        FlashStorage::new(Nor(vec![0xFF; 4 * SECTOR]), 0..(4 * SECTOR) as u32).expect("range");
    let mut stalls = Vec::new();
    // 200 saves: the four sectors fill and wrap ten times (items carried
    // over, sectors erased), and a load after each.
    for n in 0..200u32 {
        let (r, longest, polls) = timed(storage.save(&Pattern(n as u8)));
        r.expect("save");
        stalls.push(longest);
        let (r, longest_load, _) = timed(storage.load());
        assert_eq!(r.expect("load").len(), IMAGE_LEN);
        stalls.push(longest_load);
        if n == 0 {
            println!("a save: {polls} polls");
        }
    }
    stalls.sort();
    println!(
        "longest synchronous step of a save or load, 200 saves of {IMAGE_LEN} bytes over 4 x 16 KiB sectors: max {:?}, p99 {:?}, p50 {:?} (this host)",
        stalls[stalls.len() - 1],
        stalls[stalls.len() * 99 / 100],
        stalls[stalls.len() / 2]
    );
}
