//! CRC-32 (IEEE 802.3, reflected: the zlib / PNG one), the check of the
//! stored image and of each audit record: a leaf, so that the audit log and
//! the storage share it without importing each other.

/// CRC-32 of `data`, bitwise: a few bytes of code for checks run at load,
/// save and when a record is kept, not worth a dependency (or a table's
/// 1 KiB of flash). Public for tools and fuzz targets that build or reseal
/// images.
pub fn crc32(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in data {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_check_value_is_the_standards() {
        assert_eq!(super::crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(super::crc32(b""), 0);
    }
}
