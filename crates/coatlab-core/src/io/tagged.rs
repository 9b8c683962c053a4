//! The start the project's own binary files share: an 8-byte signature followed by
//! two little-endian `u32` words (a film part's version and header length, an XYZ
//! image's width and height).

/// Bytes before a tagged file's body: the signature and the two words.
pub const TAGGED_HEADER_BYTES: usize = 16;

/// The two words after `signature`, or `None` when `bytes` is shorter than
/// [`TAGGED_HEADER_BYTES`] or starts with something else.
pub fn tagged_header(bytes: &[u8], signature: &[u8; 8]) -> Option<[u32; 2]> {
    let header = bytes.get(..TAGGED_HEADER_BYTES)?;
    if &header[..8] != signature {
        return None;
    }
    let word =
        |i: usize| u32::from_le_bytes([header[i], header[i + 1], header[i + 2], header[i + 3]]);
    Some([word(8), word(12)])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_two_words_after_the_signature() {
        let mut bytes = b"COATTEST".to_vec();
        bytes.extend_from_slice(&7u32.to_le_bytes());
        bytes.extend_from_slice(&0x0102_0304u32.to_le_bytes());
        assert_eq!(tagged_header(&bytes, b"COATTEST"), Some([7, 0x0102_0304]));
        assert_eq!(tagged_header(&bytes, b"COATFILM"), None);
        assert_eq!(tagged_header(&bytes[..15], b"COATTEST"), None);
    }
}
