//! Configuration storage in NOR flash that survives a power cut at any
//! moment of a save: the stored image is one item of a sequential-storage
//! map (key 0) spread over two or more flash sectors. A new image is written
//! beside the old one; the old one only stops counting once the new one is
//! complete and its CRC checks, and a sector is erased only after its
//! items were carried over. So a load after a power cut finds the old image
//! or the new one, never none.
//!
//! The audit log's records (feature `audit`) go into a second range of
//! sectors of the same flash ([`FlashStorage::with_audit`]): a
//! sequential-storage queue, each record one item with its own CRC. When
//! the range is full, the sector of the oldest records is erased for the
//! new ones (the newest are kept). A power cut while a record is written
//! loses at most that record: an item is only read back whole (a torn one
//! fails its CRC and is skipped), and erasing a sector of old records never
//! touches another sector.
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
use sequential_storage::queue::{QueueConfig, QueueStorage};

use sequential_storage::map::{SerializationError, Value};

use super::{AuditStore, ConfigStore, Image, Medium, StorageError, IMAGE_MAX};

/// No cache: one item, read once at start and written on rare saves.
type Uncached3 = Cache<Uncached, Uncached, Uncached, u8>;
/// No cache for the audit queue either: it is read once at start, and
/// appended to.
type UncachedQueue = Cache<Uncached, Uncached, Uncached, ()>;

/// The configuration's map, over the flash borrowed for one operation.
type Map<'f, F> = MapStorage<u8, &'f mut F, Uncached3>;

/// The map key of the image.
const KEY: u8 = 0;

/// Bytes of the work buffer sequential-storage needs: the key, the image,
/// rounded up to any flash word (32 bytes at most). An audit record (at
/// most 128 bytes) is read back through it too.
pub const DATA_BUF: usize = (1 + IMAGE_MAX).next_multiple_of(32);

/// The flash range is not usable: it must start and end on erase-sector
/// boundaries and span at least two sectors (each range, and the audit
/// range must not overlap the configuration's).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BadRange;

/// The stored image in NOR flash `F`, within a range of its sectors (and
/// the audit records in another range, when given).
pub struct FlashStorage<F: NorFlash> {
    flash: F,
    config: Range<u32>,
    audit: Option<Range<u32>>,
    buf: [u8; DATA_BUF],
}

impl<F: NorFlash> FlashStorage<F> {
    /// Storage in `range` of `flash` (offsets from the flash's start); no
    /// audit records are kept.
    pub fn new(flash: F, range: Range<u32>) -> Result<Self, BadRange> {
        MapConfig::<F>::try_new(range.clone()).map_err(|_| BadRange)?;
        Ok(FlashStorage {
            flash,
            config: range,
            audit: None,
            buf: [0; DATA_BUF],
        })
    }

    /// Storage in `config` of `flash`, and the audit records in `audit`
    /// (two sectors or more, apart from `config`; when full, the oldest
    /// sector's records are erased for new ones).
    pub fn with_audit(flash: F, config: Range<u32>, audit: Range<u32>) -> Result<Self, BadRange> {
        let sectors = (audit.end.saturating_sub(audit.start)) / F::ERASE_SIZE as u32;
        let apart = audit.end <= config.start || config.end <= audit.start;
        if sectors < 2 || !apart {
            return Err(BadRange);
        }
        QueueConfig::<F>::try_new(audit.clone()).map_err(|_| BadRange)?;
        let mut s = FlashStorage::new(flash, config)?;
        s.audit = Some(audit);
        Ok(s)
    }

    /// The flash back (tests: power it up again).
    pub fn into_flash(self) -> F {
        self.flash
    }

    /// The configuration's map over the flash, and the work buffer.
    fn map(&mut self) -> Result<(Map<'_, F>, &mut [u8]), StorageError> {
        let config = MapConfig::try_new(self.config.clone()).map_err(|_| StorageError::Io)?;
        let map = MapStorage::new(&mut self.flash, config, Cache::new_uncached());
        Ok((map, &mut self.buf))
    }

    /// The audit records' queue over the flash, and the work buffer
    /// (`None`: no audit range).
    fn queue(&mut self) -> Option<(QueueStorage<&mut F, UncachedQueue>, &mut [u8])> {
        let config = QueueConfig::try_new(self.audit.clone()?).ok()?;
        let queue = QueueStorage::new(&mut self.flash, config, Cache::new_uncached());
        Some((queue, &mut self.buf))
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

impl<F: NorFlash> ConfigStore for FlashStorage<F> {
    async fn load(&mut self) -> Result<&[u8], StorageError> {
        let (mut map, buf) = self.map()?;
        match map.fetch_item::<&[u8]>(buf, &KEY).await {
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
        let (mut map, buf) = self.map()?;
        match map.store_item(buf, &KEY, &image).await {
            Ok(()) => Ok(()),
            Err(sequential_storage::Error::Corrupted { .. }) => {
                // Damaged beyond repair (not by a power cut: by something
                // else writing there). What it held is lost anyway; start
                // the range afresh rather than refuse every save.
                warn!("config: flash storage corrupted, erasing it");
                map.erase_all().await.map_err(|_| StorageError::Io)?;
                map.store_item(buf, &KEY, &image)
                    .await
                    .map_err(|_| StorageError::Io)
            }
            Err(sequential_storage::Error::ItemTooBig) => Err(StorageError::TooLarge),
            Err(_) => Err(StorageError::Io),
        }
    }

    fn medium(&self) -> Medium {
        Medium::Flash
    }
}

impl<F: NorFlash> AuditStore for FlashStorage<F> {
    async fn read(&mut self, each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError> {
        let Some((mut queue, buf)) = self.queue() else {
            return Ok(());
        };
        let mut items = queue.iter().await.map_err(|_| StorageError::Io)?;
        while let Some(item) = items.next(buf).await.map_err(|_| StorageError::Io)? {
            each(&item);
        }
        Ok(())
    }

    async fn append(&mut self, record: &[u8]) -> Result<(), StorageError> {
        let Some((mut queue, _)) = self.queue() else {
            return Ok(());
        };
        // Full: the oldest sector's records make room.
        match queue.push(record, true).await {
            Ok(()) => Ok(()),
            Err(sequential_storage::Error::Corrupted { .. }) => {
                // As for the configuration: damaged by something else than
                // a power cut; the records there are lost anyway.
                warn!("audit: flash ring corrupted, erasing it");
                queue.erase_all().await.map_err(|_| StorageError::Io)?;
                queue.push(record, true).await.map_err(|_| StorageError::Io)
            }
            Err(sequential_storage::Error::ItemTooBig) => Err(StorageError::TooLarge),
            Err(_) => Err(StorageError::Io),
        }
    }

    fn persistent(&self) -> bool {
        self.audit.is_some()
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
    #[derive(Clone)]
    struct NorS<const S: usize> {
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

    /// The configuration tests' flash: two 16 KiB sectors.
    type Nor = NorS<SECTOR>;

    impl<const S: usize> ErrorType for NorS<S> {
        type Error = NorError;
    }

    impl Nor {
        fn new() -> Self {
            NorS::sized(SECTORS)
        }
    }

    impl<const S: usize> NorS<S> {
        fn sized(sectors: usize) -> Self {
            NorS {
                mem: vec![0xFF; S * sectors],
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

    impl<const S: usize> ReadNorFlash for NorS<S> {
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

    impl<const S: usize> NorFlash for NorS<S> {
        const WRITE_SIZE: usize = 4;
        const ERASE_SIZE: usize = S;
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

    // ---- the audit ring

    /// Small sectors, so that the ring wraps after a few dozen records.
    const SMALL: usize = 1024;
    type SmallNor = NorS<SMALL>;

    /// Two sectors of configuration, three of audit records.
    fn ring(nor: SmallNor) -> FlashStorage<SmallNor> {
        let s = SMALL as u32;
        FlashStorage::with_audit(nor, 0..2 * s, 2 * s..5 * s).unwrap()
    }

    /// Record `seq`: its number, then a pattern of a length that varies
    /// (36 to 128 bytes, as audit records do) and depends on the number.
    fn record(seq: u32) -> Vec<u8> {
        let len = 36 + (seq as usize * 37) % 93;
        let mut r = seq.to_le_bytes().to_vec();
        r.extend((4..len).map(|i| (seq as usize * 7 + i) as u8));
        r
    }

    /// The records read back, oldest first; each must be whole.
    fn records(s: &mut FlashStorage<SmallNor>) -> Vec<u32> {
        let mut got = Vec::new();
        block_on(s.read(&mut |b| {
            let seq = u32::from_le_bytes(b[..4].try_into().unwrap());
            assert_eq!(b, record(seq).as_slice(), "record {seq} damaged");
            got.push(seq);
        }))
        .unwrap();
        got
    }

    #[test]
    fn audit_ranges_are_whole_sectors_apart_from_the_configuration() {
        let s = SMALL as u32;
        let ok = |c: Range<u32>, a: Range<u32>| {
            FlashStorage::with_audit(SmallNor::sized(6), c, a).is_ok()
        };
        assert!(ok(0..2 * s, 2 * s..4 * s));
        assert!(ok(4 * s..6 * s, 0..4 * s));
        assert!(
            !ok(0..2 * s, 2 * s..3 * s),
            "one sector: a wrap would erase all"
        );
        assert!(!ok(0..2 * s, s..3 * s), "overlapping");
        assert!(!ok(0..2 * s, 2 * s + 4..4 * s), "not on a sector");
        // Without an audit range nothing is kept, and nothing fails.
        let mut plain = FlashStorage::new(SmallNor::sized(2), 0..2 * s).unwrap();
        assert!(!plain.persistent());
        block_on(plain.append(&record(1))).unwrap();
        let mut n = 0;
        block_on(plain.read(&mut |_| n += 1)).unwrap();
        assert_eq!(n, 0);
    }

    #[test]
    fn the_ring_keeps_the_newest_records_across_restarts() {
        let mut s = ring(SmallNor::sized(5));
        assert!(s.persistent());
        assert_eq!(records(&mut s), Vec::<u32>::new());
        for seq in 1..=200 {
            block_on(s.append(&record(seq))).unwrap();
        }
        let mut s = ring(s.into_flash().power_up());
        let got = records(&mut s);
        // Full: the newest are kept, in order, with no gap; two of the
        // three sectors' worth at least.
        assert_eq!(got.last(), Some(&200));
        assert!(got.len() > 2 * SMALL / 128, "only {} kept", got.len());
        assert!(got.windows(2).all(|w| w[1] == w[0] + 1), "{got:?}");
        // The configuration beside it is untouched, and vice versa.
        block_on(s.save(&SmallImage)).unwrap();
        block_on(s.append(&record(201))).unwrap();
        let mut s = ring(s.into_flash().power_up());
        assert_eq!(block_on(s.load()).unwrap(), SmallImage::BYTES);
        assert_eq!(records(&mut s).last(), Some(&201));
    }

    /// A small configuration image (the small sectors hold it).
    struct SmallImage;
    impl SmallImage {
        const BYTES: &[u8] = b"a configuration";
    }
    impl Image for SmallImage {
        fn write(&self, out: &mut [u8]) -> Result<usize, StorageError> {
            let n = Self::BYTES.len();
            out.get_mut(..n)
                .ok_or(StorageError::TooLarge)?
                .copy_from_slice(Self::BYTES);
            Ok(n)
        }
    }

    /// The power goes after every single flash operation of an append in
    /// turn, at every fill level of the ring (so that appends that erase
    /// the oldest sector are cut too): each time, the flash powered up again
    /// holds whole records only, in order, every record that the append
    /// would have kept (all but those of the erased sector) and nothing new
    /// but the record being written; and the next append works.
    #[test]
    fn a_power_cut_during_an_append_loses_at_most_that_record() {
        let mut cuts = 0;
        let mut wraps = 0;
        // ~15 records a sector, three sectors: 100 records wrap twice.
        for history in 0..100u32 {
            let mut s = ring(SmallNor::sized(5));
            for seq in 1..=history {
                block_on(s.append(&record(seq))).unwrap();
            }
            let before = records(&mut s);
            let base = s.into_flash();
            // What an append that is not cut does.
            let mut nor = base.clone();
            nor.ops = 0;
            let mut s = ring(nor);
            let new = history + 1;
            block_on(s.append(&record(new))).unwrap();
            let full = records(&mut s);
            let ops = s.into_flash().ops;
            assert_eq!(full.last(), Some(&new));
            if full.len() <= before.len() {
                wraps += 1;
            }
            for budget in 0..ops {
                let mut nor = base.clone();
                nor.ops = 0;
                nor.budget = Some(budget);
                let mut s = ring(nor);
                assert!(block_on(s.append(&record(new))).is_err());
                let mut s = ring(s.into_flash().power_up());
                let got = records(&mut s);
                let why =
                    format!("history {history}, cut after {budget} of {ops} operations: {got:?}");
                assert!(got.windows(2).all(|w| w[0] < w[1]), "{why}");
                for seq in &got {
                    assert!(before.contains(seq) || *seq == new, "{why}");
                }
                for seq in full.iter().filter(|&&q| q != new) {
                    assert!(got.contains(seq), "record {seq} lost: {why}");
                }
                block_on(s.append(&record(500))).unwrap();
                assert_eq!(records(&mut s).last(), Some(&500), "{why}");
                cuts += 1;
            }
        }
        assert!(wraps > 3, "only {wraps} appends erased a sector");
        assert!(cuts >= 300, "only {cuts} cuts tried");
    }
}
