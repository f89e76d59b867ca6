//! PNG encoding of RGB8 buffers (8 bits per channel, best compression), to memory or
//! to a file written through [`crate::io::write_atomic`].

use std::io::Write;
use std::path::Path;

/// Encodes `rgb` (`width·height·3` bytes, top row first) as PNG into `out`. Fails on
/// a zero size or a buffer of the wrong length; the encoder's error is kept as the
/// source of the returned [`std::io::Error`].
pub fn encode_into(
    out: &mut dyn Write,
    width: u32,
    height: u32,
    rgb: &[u8],
) -> std::io::Result<()> {
    let mut enc = png::Encoder::new(out, width, height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_compression(png::Compression::Best);
    let mut writer = enc.write_header().map_err(std::io::Error::other)?;
    writer
        .write_image_data(rgb)
        .map_err(std::io::Error::other)?;
    writer.finish().map_err(std::io::Error::other)
}

/// The PNG file of an RGB8 buffer, in memory (see [`encode_into`]).
pub fn encode(width: u32, height: u32, rgb: &[u8]) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::new();
    encode_into(&mut out, width, height, rgb)?;
    Ok(out)
}

/// Writes an RGB8 buffer as a PNG file, atomically: on any error `path` is untouched
/// and no temporary file is left behind.
pub fn write(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<(), crate::io::IoError> {
    crate::io::write_atomic(path, |out| encode_into(out, width, height, rgb))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_atomic_failure() {
        let rgb: Vec<u8> = (0..2 * 3 * 3).map(|i| (i * 13) as u8).collect();
        let bytes = encode(2, 3, &rgb).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
            .read_info()
            .unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (2, 3));
        assert_eq!(&buf[..info.buffer_size()], &rgb[..]);

        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("short.png");
        assert!(write(&path, 2, 3, &rgb[..5]).is_err());
        assert!(encode(0, 3, &[]).is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
