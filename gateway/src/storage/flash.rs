//! Configuration storage in NOR flash that survives a power cut at any
//! moment of a save: the stored image is one item of a sequential-storage
//! map (key 0) spread over two or more flash sectors. A new image is written
//! beside the old one; the old one only stops counting once the new one is
//! complete and its CRC checks, and a sector is erased only after its
//! items were carried over. So a load after a power cut finds the old image
//! or the new one, never none.
//!
//! The flash is driven through embedded-storage-async's `NorFlash`: a board
//! whose flash can erase and program while the CPU runs (a second bank)
//! yields during each operation, and a save never stops the executor for
//! more than one program step.
//!
//! Why not a simpler two-slot scheme of our own: sequential-storage is the
//! well-kept crate for this (wear spread over the sectors, repair after a
//! torn write, tested against power loss by its authors), and it costs less
//! flash than a careful hand-written equivalent would.

use core::ops::Range;

use embedded_storage_async::nor_flash::NorFlash;
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage};

use sequential_storage::map::{SerializationError, Value};

use super::{Image, Storage, StorageError, IMAGE_MAX};

/// No cache: one item, read once at start and written on rare saves.
type Uncached3 = Cache<Uncached, Uncached, Uncached, u8>;

/// The map key of the image.
const KEY: u8 = 0;

/// Bytes of the work buffer sequential-storage needs: the key, the image,
/// rounded up to any flash word (32 bytes at most).
pub const DATA_BUF: usize = (1 + IMAGE_MAX).next_multiple_of(32);

/// The flash range is not usable: it must start and end on erase-sector
/// boundaries and span at least two sectors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BadRange;

/// The stored image in NOR flash `F`, within a range of its sectors.
pub struct FlashStorage<F: NorFlash> {
    map: MapStorage<u8, F, Uncached3>,
    buf: [u8; DATA_BUF],
}

impl<F: NorFlash> FlashStorage<F> {
    /// Storage in `range` of `flash` (offsets from the flash's start).
    pub fn new(flash: F, range: Range<u32>) -> Result<Self, BadRange> {
        let config = MapConfig::try_new(range).map_err(|_| BadRange)?;
        Ok(FlashStorage {
            map: MapStorage::new(flash, config, Cache::new_uncached()),
            buf: [0; DATA_BUF],
        })
    }

    /// The flash back (tests: power it up again).
    pub fn into_flash(self) -> F {
        self.map.destroy().0
    }
}

/// An image as a map value: written straight into the map's buffer.
struct Item<'a>(&'a dyn Image);

impl<'a> Value<'a> for Item<'_> {
    fn serialize_into(&self, buffer: &mut [u8]) -> Result<usize, SerializationError> {
        self.0
            .write(buffer)
            .map_err(|_| SerializationError::BufferTooSmall)
    }

    fn deserialize_from(_: &'a [u8]) -> Result<(Self, usize), SerializationError> {
        // Only ever stored; read back as bytes.
        Err(SerializationError::InvalidFormat)
    }
}

impl<F: NorFlash> Storage for FlashStorage<F> {
    async fn load(&mut self) -> Result<&[u8], StorageError> {
        match self.map.fetch_item::<&[u8]>(&mut self.buf, &KEY).await {
            Ok(Some(image)) => Ok(image),
            Ok(None) => Ok(&[]),
            Err(_) => {
                warn!("config: flash storage unreadable");
                Err(StorageError::Io)
            }
        }
    }

    async fn save(&mut self, image: &dyn Image) -> Result<(), StorageError> {
        let image = Item(image);
        match self.map.store_item(&mut self.buf, &KEY, &image).await {
            Ok(()) => Ok(()),
            Err(sequential_storage::Error::Corrupted { .. }) => {
                // Damaged beyond repair (not by a power cut: by something
                // else writing there). What it held is lost anyway; start
                // the range afresh rather than refuse every save.
                warn!("config: flash storage corrupted, erasing it");
                self.map.erase_all().await.map_err(|_| StorageError::Io)?;
                self.map
                    .store_item(&mut self.buf, &KEY, &image)
                    .await
                    .map_err(|_| StorageError::Io)
            }
            Err(sequential_storage::Error::ItemTooBig) => Err(StorageError::TooLarge),
            Err(_) => Err(StorageError::Io),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::storage::IMAGE_LEN;
    use embassy_futures::block_on;
    use embedded_storage_async::nor_flash::{
        ErrorType, NorFlashError, NorFlashErrorKind, ReadNorFlash,
    };

    const SECTOR: usize = 16 * 1024;
    const SECTORS: usize = 2;

    /// NOR flash in RAM with the rules of a real part (erase sets a sector
    /// to 0xFF; a word can only be programmed while erased), and a power
    /// switch: after `budget` operations the power goes; the operation it
    /// goes in is torn (half an erase, part of a write) and every later one
    /// fails.
    struct Nor {
        mem: Vec<u8>,
        budget: Option<usize>,
        ops: usize,
        off: bool,
    }

    #[derive(Debug)]
    enum NorError {
        PowerOff,
        NotErased,
        Bounds,
    }

    impl NorFlashError for NorError {
        fn kind(&self) -> NorFlashErrorKind {
            match self {
                NorError::Bounds => NorFlashErrorKind::OutOfBounds,
                _ => NorFlashErrorKind::Other,
            }
        }
    }

    impl ErrorType for Nor {
        type Error = NorError;
    }

    impl Nor {
        fn new() -> Self {
            Nor {
                mem: vec![0xFF; SECTOR * SECTORS],
                budget: None,
                ops: 0,
                off: false,
            }
        }

        /// Counts an operation; `true` if the power goes during it.
        fn op(&mut self) -> Result<bool, NorError> {
            if self.off {
                return Err(NorError::PowerOff);
            }
            self.ops += 1;
            let cut = self.budget.is_some_and(|b| self.ops > b);
            self.off = cut;
            Ok(cut)
        }

        fn power_up(mut self) -> Self {
            self.budget = None;
            self.ops = 0;
            self.off = false;
            self
        }
    }

    impl ReadNorFlash for Nor {
        const READ_SIZE: usize = 1;
        async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), NorError> {
            if self.off {
                return Err(NorError::PowerOff);
            }
            let o = offset as usize;
            let src = self.mem.get(o..o + bytes.len()).ok_or(NorError::Bounds)?;
            bytes.copy_from_slice(src);
            Ok(())
        }
        fn capacity(&self) -> usize {
            self.mem.len()
        }
    }

    impl NorFlash for Nor {
        const WRITE_SIZE: usize = 4;
        const ERASE_SIZE: usize = SECTOR;
        async fn erase(&mut self, from: u32, to: u32) -> Result<(), NorError> {
            let cut = self.op()?;
            let range = self
                .mem
                .get_mut(from as usize..to as usize)
                .ok_or(NorError::Bounds)?;
            if cut {
                // Half erased: the first half only.
                let half = range.len() / 2;
                range[..half].fill(0xFF);
                return Err(NorError::PowerOff);
            }
            range.fill(0xFF);
            Ok(())
        }
        async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), NorError> {
            let cut = self.op()?;
            let o = offset as usize;
            let dst = self
                .mem
                .get_mut(o..o + bytes.len())
                .ok_or(NorError::Bounds)?;
            if dst.iter().any(|&b| b != 0xFF) {
                return Err(NorError::NotErased);
            }
            // Torn: only the first half of the words made it.
            let n = if cut {
                (bytes.len() / 8) * 4
            } else {
                bytes.len()
            };
            dst[..n].copy_from_slice(&bytes[..n]);
            if cut {
                Err(NorError::PowerOff)
            } else {
                Ok(())
            }
        }
    }

    fn image(tag: u8) -> Bytes {
        let mut i = [0u8; IMAGE_LEN];
        for (k, b) in i.iter_mut().enumerate() {
            *b = tag.wrapping_add(k as u8);
        }
        Bytes(i)
    }

    #[derive(Debug, PartialEq)]
    struct Bytes([u8; IMAGE_LEN]);

    impl Image for Bytes {
        fn write(&self, out: &mut [u8]) -> Result<usize, StorageError> {
            let dst = out.get_mut(..IMAGE_LEN).ok_or(StorageError::TooLarge)?;
            dst.copy_from_slice(&self.0);
            Ok(IMAGE_LEN)
        }
    }

    fn storage(nor: Nor) -> FlashStorage<Nor> {
        FlashStorage::new(nor, 0..(SECTOR * SECTORS) as u32).unwrap()
    }

    fn load(s: &mut FlashStorage<Nor>) -> Option<Bytes> {
        match block_on(s.load()) {
            Ok([]) => None,
            Ok(b) => Some(Bytes(b.try_into().expect("an image"))),
            Err(e) => panic!("load: {e:?}"),
        }
    }

    #[test]
    fn a_range_must_be_two_sectors_or_more() {
        assert!(FlashStorage::new(Nor::new(), 0..SECTOR as u32).is_err());
        assert!(FlashStorage::new(Nor::new(), 1..(2 * SECTOR) as u32).is_err());
    }

    #[test]
    fn saves_survive_a_restart() {
        let mut s = storage(Nor::new());
        assert_eq!(load(&mut s), None);
        block_on(s.save(&image(1))).unwrap();
        block_on(s.save(&image(2))).unwrap();
        let mut s = storage(s.into_flash().power_up());
        assert_eq!(load(&mut s), Some(image(2)));
    }

    /// The power goes after every single flash operation of a save in
    /// turn, at every fill level of the sectors (so that saves that carry
    /// items over and erase a sector are cut too): each time, the flash
    /// powered up again holds the old image or the new one, and the next
    /// save works.
    #[test]
    fn a_power_cut_at_any_moment_of_a_save_leaves_the_old_or_the_new_image() {
        let mut cuts = 0;
        // Five images fill a sector: 24 saves wrap the two sectors twice.
        for history in 1..24u8 {
            // How many operations a save takes at this fill level.
            let mut s = storage(Nor::new());
            for t in 1..=history {
                block_on(s.save(&image(t))).unwrap();
            }
            let mut nor = s.into_flash();
            nor.ops = 0;
            let mut s = storage(nor);
            block_on(s.save(&image(100))).unwrap();
            let ops = s.into_flash().ops;
            assert!(ops > 0);
            for budget in 0..ops {
                let mut s = storage(Nor::new());
                for t in 1..=history {
                    block_on(s.save(&image(t))).unwrap();
                }
                let mut nor = s.into_flash();
                nor.ops = 0;
                nor.budget = Some(budget);
                let mut s = storage(nor);
                assert!(block_on(s.save(&image(100))).is_err(), "budget {budget}");
                let mut s = storage(s.into_flash().power_up());
                let got = load(&mut s);
                assert!(
                    got == Some(image(history)) || got == Some(image(100)),
                    "history {history}, cut after {budget} of {ops} operations: neither image"
                );
                block_on(s.save(&image(200))).unwrap();
                assert_eq!(load(&mut s), Some(image(200)));
                cuts += 1;
            }
        }
        assert!(cuts > 80, "only {cuts} cuts tried");
    }
}
