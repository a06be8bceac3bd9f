//! Input files read whole, with a bound on their size: a path such as `/dev/zero` given for a
//! kit or a map must not be read until memory runs out.

use std::io::Read;
use std::path::Path;

/// Kit and note-map files: the shipped ones are about 10 kB.
pub const MAX_CONFIG_BYTES: u64 = 4 << 20;
/// Motion, mocap and trajectory JSON: a 23-minute take's motion is about 200 MB.
pub const MAX_DATA_BYTES: u64 = 1 << 30;

/// The whole of `path` as UTF-8 text, refused (`InvalidData`) past `max` bytes.
pub fn read_to_string_bounded(path: &Path, max: u64) -> std::io::Result<String> {
    let mut text = String::new();
    std::fs::File::open(path)?.take(max + 1).read_to_string(&mut text)?;
    if text.len() as u64 > max {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("larger than {} MiB, the most this kind of file may hold", max >> 20),
        ));
    }
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_endless_file_is_refused_at_the_bound() {
        let e = read_to_string_bounded(Path::new("/dev/zero"), 1 << 20).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidData);
        assert!(e.to_string().contains("1 MiB"), "{e}");
    }
}
