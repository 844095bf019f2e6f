//! The container every texel-forest binary file shares (see `formats/container.md`):
//!
//! ```text
//! offset  size  field
//!      0     8  magic, one per format
//!      8     2  major version, u16 LE (incompatible layout when it changes)
//!     10     2  minor version, u16 LE (compatible additions)
//!     12     4  header length H, u32 LE
//!     16     8  payload length once decompressed R, u64 LE
//!     24     8  payload length as stored P, u64 LE
//!     32     H  header: bincode 2, little-endian fixed-width integers
//!   32+H     P  payload: one zstd frame that decompresses to R bytes
//! 32+H+P     4  CRC-32 (IEEE, as zlib's crc32) of every byte before it
//! ```
//!
//! Reading checks, in order: length, magic, major version, the declared lengths against the
//! file's, the checksum, then decodes the header with a size limit, and the payload with a
//! bounded stream, so no field of a damaged or hostile file can make us allocate more than the
//! limits below.

use std::io::Read;

/// Fixed part before the header.
pub const PREAMBLE: usize = 32;
/// The bincode configuration of every header: fixed, so the bytes never depend on defaults.
pub const fn header_config() -> bincode::config::Configuration<
    bincode::config::LittleEndian,
    bincode::config::Fixint,
    bincode::config::Limit<MAX_HEADER>,
> {
    bincode::config::standard()
        .with_little_endian()
        .with_fixed_int_encoding()
        .with_limit::<MAX_HEADER>()
}
/// Largest header accepted (16 MiB: a species table of 255 species with long series fits).
pub const MAX_HEADER: usize = 16 << 20;
/// Largest decompressed payload accepted (2 GiB).
pub const MAX_PAYLOAD: u64 = 2 << 30;
/// zstd level: a fixed level keeps output bytes reproducible.
const ZSTD_LEVEL: i32 = 9;

#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum ContainerError {
    #[error(
        "not {} {format} file (wrong magic bytes{hint})",
        if format.starts_with(['a', 'e', 'i', 'o', 'u']) { "an" } else { "a" }
    )]
    Magic { format: &'static str, hint: String },
    #[error("{}", version_message(format, *major, *minor, *supported))]
    Version {
        format: &'static str,
        major: u16,
        minor: u16,
        /// The major version this reader implements.
        supported: u16,
    },
    #[error("truncated: {0}")]
    Truncated(String),
    #[error("corrupt: {0}")]
    Corrupt(String),
    #[error("too large to write: {0}")]
    TooLarge(String),
}

fn version_message(format: &str, major: u16, minor: u16, supported: u16) -> String {
    if major > supported {
        format!(
            "{format} format version {major}.{minor} is newer than this reader ({supported}.x); \
             update texel-forest, or re-create the file with this one"
        )
    } else {
        format!(
            "{format} format version {major}.{minor} is older than this reader ({supported}.x) \
             and cannot be read; re-create the file with this texel-forest"
        )
    }
}

/// A parsed container: the format's version, its header bytes and its decompressed payload.
#[derive(Debug)]
pub struct Container {
    pub minor: u16,
    pub header: Vec<u8>,
    pub payload: Vec<u8>,
}

/// Assembles a container around an encoded header and a raw payload.
pub fn write(
    magic: &[u8; 8],
    major: u16,
    minor: u16,
    header: &[u8],
    payload: &[u8],
) -> Result<Vec<u8>, ContainerError> {
    // What readers would refuse, writers refuse to write.
    if header.len() > MAX_HEADER {
        return Err(ContainerError::TooLarge(format!(
            "a header of {} bytes (at most {MAX_HEADER})",
            header.len()
        )));
    }
    if payload.len() as u64 > MAX_PAYLOAD {
        return Err(ContainerError::TooLarge(format!(
            "a payload of {} bytes (at most {MAX_PAYLOAD})",
            payload.len()
        )));
    }
    let compressed =
        zstd::bulk::compress(payload, ZSTD_LEVEL).expect("in-memory zstd compression cannot fail");
    let mut out = Vec::with_capacity(PREAMBLE + header.len() + compressed.len() + 4);
    out.extend_from_slice(magic);
    out.extend_from_slice(&major.to_le_bytes());
    out.extend_from_slice(&minor.to_le_bytes());
    out.extend_from_slice(&(header.len() as u32).to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&(compressed.len() as u64).to_le_bytes());
    out.extend_from_slice(header);
    out.extend_from_slice(&compressed);
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    Ok(out)
}

fn u16_at(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}
fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}
fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes"))
}

/// A header that does not decode, said in words (bincode's own texts include debug names).
pub fn decode_error(e: &bincode::error::DecodeError) -> String {
    use bincode::error::DecodeError as E;
    match e {
        E::LimitExceeded | E::UnexpectedEnd { .. } => {
            "a length or field runs past the end of the header".into()
        }
        E::Utf8 { .. } => "a string is not valid UTF-8".into(),
        E::UnexpectedVariant { found, .. } => {
            format!("an enum or option tag {found} is not one the format defines")
        }
        E::InvalidBooleanValue(v) => format!("boolean byte {v} is neither 0 nor 1"),
        E::OutsideUsizeRange(n) => format!("a length of {n} cannot be held"),
        other => format!("it does not decode ({other})"),
    }
}

/// The most bytes a zstd frame of `raw` bytes may take (above zstd's own bound,
/// `raw + raw/256 + 64`): a larger `P` is damage, not compression.
pub fn max_stored(raw: u64) -> u64 {
    raw + raw / 128 + 4096
}

/// Reads a container file: its preamble first, then only as many bytes as the preamble
/// promises (one more, to see trailing data), within the limits of step 4. A file that is not a
/// container, or whose preamble is absurd, is read no further than its preamble, and the
/// reader then refuses it with the right message.
pub fn read_file(path: &std::path::Path) -> Result<Vec<u8>, crate::input::InputError> {
    crate::input::read_framed(path, PREAMBLE, |b| {
        if b.len() < PREAMBLE {
            return None;
        }
        let (h, r, p) = (u32_at(b, 12) as u64, u64_at(b, 16), u64_at(b, 24));
        // Absurd lengths: no more than the CRC's four bytes, so that reading stops at step 4
        // (which names the length) rather than at step 2 (truncated).
        Some(
            if h <= MAX_HEADER as u64 && r <= MAX_PAYLOAD && p <= max_stored(r) {
                PREAMBLE as u64 + 4 + h + p
            } else {
                PREAMBLE as u64 + 4
            },
        )
    })
}

/// The fixed fields of a container's preamble, read without any check: for describing a file
/// that has already been read successfully.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Preamble {
    pub major: u16,
    pub minor: u16,
    pub header_len: u32,
    pub raw_len: u64,
    pub stored_len: u64,
}

pub fn preamble(bytes: &[u8]) -> Option<Preamble> {
    (bytes.len() >= PREAMBLE).then(|| Preamble {
        major: u16_at(bytes, 8),
        minor: u16_at(bytes, 10),
        header_len: u32_at(bytes, 12),
        raw_len: u64_at(bytes, 16),
        stored_len: u64_at(bytes, 24),
    })
}

/// A container whose framing and checksum have been verified, payload still compressed.
pub struct Opened<'a> {
    pub minor: u16,
    pub header: &'a [u8],
    compressed: &'a [u8],
    raw_len: u64,
}

/// Checks and opens a container of format `format` (named in errors) with `magic` and major
/// version `major`, and decompresses its payload.
pub fn read(
    bytes: &[u8],
    magic: &[u8; 8],
    format: &'static str,
    major: u16,
) -> Result<Container, ContainerError> {
    let opened = open(bytes, magic, format, major)?;
    let payload = opened.payload()?;
    Ok(Container {
        minor: opened.minor,
        header: opened.header.to_vec(),
        payload,
    })
}

/// Steps 1 to 5 of reading (see `formats/container.md`): magic, length, version, lengths,
/// checksum.
pub fn open<'a>(
    bytes: &'a [u8],
    magic: &[u8; 8],
    format: &'static str,
    major: u16,
) -> Result<Opened<'a>, ContainerError> {
    if bytes.len() < 8 || &bytes[..8] != magic {
        let hint = if bytes.len() >= 8 && bytes[1..8] == magic[1..8] {
            ", the first byte was altered".to_string()
        } else if bytes.starts_with(b"glTF") || bytes.starts_with(b"{") {
            "; it looks like glTF or JSON".to_string()
        } else {
            String::new()
        };
        if bytes.len() < 8 && magic.starts_with(bytes) {
            return Err(ContainerError::Truncated(format!(
                "{} bytes, not even a magic number",
                bytes.len()
            )));
        }
        return Err(ContainerError::Magic { format, hint });
    }
    if bytes.len() < PREAMBLE + 4 {
        return Err(ContainerError::Truncated(format!(
            "{} bytes, shorter than the fixed header",
            bytes.len()
        )));
    }
    let (file_major, minor) = (u16_at(bytes, 8), u16_at(bytes, 10));
    if file_major != major {
        return Err(ContainerError::Version {
            format,
            major: file_major,
            minor,
            supported: major,
        });
    }
    let header_len = u32_at(bytes, 12) as u64;
    let raw_len = u64_at(bytes, 16);
    let stored_len = u64_at(bytes, 24);
    if header_len > MAX_HEADER as u64 {
        return Err(ContainerError::Corrupt(format!(
            "header length {header_len} exceeds {MAX_HEADER}"
        )));
    }
    if raw_len > MAX_PAYLOAD {
        return Err(ContainerError::Corrupt(format!(
            "payload length {raw_len} exceeds {MAX_PAYLOAD}"
        )));
    }
    if stored_len > max_stored(raw_len) {
        return Err(ContainerError::Corrupt(format!(
            "stored payload length {stored_len} exceeds what zstd makes of {raw_len} bytes"
        )));
    }
    let expected = (PREAMBLE as u64 + 4)
        .saturating_add(header_len)
        .saturating_add(stored_len);
    if (bytes.len() as u64) < expected {
        return Err(ContainerError::Truncated(format!(
            "{} bytes where the header promises {expected}",
            bytes.len()
        )));
    }
    if (bytes.len() as u64) > expected {
        return Err(ContainerError::Corrupt(format!(
            "{} bytes where the header promises {expected} (trailing data)",
            bytes.len()
        )));
    }
    let body = bytes.len() - 4;
    let stored_crc = u32_at(bytes, body);
    let crc = crc32fast::hash(&bytes[..body]);
    if crc != stored_crc {
        return Err(ContainerError::Corrupt(format!(
            "checksum mismatch (stored {stored_crc:08x}, computed {crc:08x})"
        )));
    }
    let header_end = PREAMBLE + header_len as usize;
    Ok(Opened {
        minor,
        header: &bytes[PREAMBLE..header_end],
        compressed: &bytes[header_end..body],
        raw_len,
    })
}

impl Opened<'_> {
    /// The payload's length once decompressed, as the preamble declares it.
    pub fn raw_len(&self) -> u64 {
        self.raw_len
    }

    /// Step 7: checks that the payload is exactly one zstd frame (no skippable frame, nothing
    /// after it) that declares its content size as R, then decompresses it as a stream with a
    /// limit, never trusting the declared length for an allocation.
    pub fn payload(&self) -> Result<Vec<u8>, ContainerError> {
        let mut payload = Vec::new();
        self.decoder()?
            .take(self.raw_len + 1)
            .read_to_end(&mut payload)
            .map_err(undecompressed)?;
        check_decompressed(payload.len() as u64, self.raw_len)?;
        Ok(payload)
    }

    /// Step 7 for a reader that decodes the payload a piece at a time, so that it never holds
    /// all R bytes besides what it decodes them into: the same checks and errors as
    /// [`Opened::payload`], the last ones when the reader calls [`PayloadStream::finish`].
    pub fn payload_stream(&self) -> Result<PayloadStream<'_>, ContainerError> {
        Ok(PayloadStream {
            decoder: self.decoder()?,
            read: 0,
            raw_len: self.raw_len,
        })
    }

    /// The checks of step 7 before decompression, and the decompressing stream.
    fn decoder(&self) -> Result<zstd::stream::read::Decoder<'_, &[u8]>, ContainerError> {
        use zstd::zstd_safe;
        let frame = self.compressed;
        if !frame.starts_with(&ZSTD_MAGIC) {
            return Err(ContainerError::Corrupt(
                "the payload does not start with a zstd frame".into(),
            ));
        }
        match zstd_safe::find_frame_compressed_size(frame) {
            Ok(n) if n == frame.len() => {}
            Ok(n) => {
                return Err(ContainerError::Corrupt(format!(
                    "{} bytes follow the payload's zstd frame (one frame only)",
                    frame.len() - n
                )));
            }
            Err(_) => {
                return Err(ContainerError::Corrupt(
                    "the payload's zstd frame is damaged".into(),
                ));
            }
        }
        match zstd_safe::get_frame_content_size(frame) {
            Ok(Some(n)) if n == self.raw_len => {}
            Ok(Some(n)) => {
                return Err(ContainerError::Corrupt(format!(
                    "the payload's zstd frame holds {n} bytes, the preamble says {}",
                    self.raw_len
                )));
            }
            _ => {
                return Err(ContainerError::Corrupt(
                    "the payload's zstd frame does not declare its content size".into(),
                ));
            }
        }
        Ok(zstd::stream::read::Decoder::with_buffer(frame)
            .map_err(|e| ContainerError::Corrupt(format!("payload: {e}")))?
            .single_frame())
    }
}

fn undecompressed(e: std::io::Error) -> ContainerError {
    ContainerError::Corrupt(format!("payload does not decompress: {e}"))
}

fn check_decompressed(len: u64, raw_len: u64) -> Result<(), ContainerError> {
    if len != raw_len {
        return Err(wrong_length(len, raw_len));
    }
    Ok(())
}

fn wrong_length(len: u64, raw_len: u64) -> ContainerError {
    ContainerError::Corrupt(format!(
        "payload decompresses to {len} bytes, the header says {raw_len}"
    ))
}

/// A payload being decompressed: [`Opened::payload_stream`].
pub struct PayloadStream<'a> {
    decoder: zstd::stream::read::Decoder<'a, &'a [u8]>,
    /// Bytes handed out so far.
    read: u64,
    raw_len: u64,
}

impl PayloadStream<'_> {
    /// Fills `buf` with the payload's next bytes, which the caller knows are within the R
    /// bytes; a payload that ends first is refused as [`Opened::payload`] refuses it.
    pub fn read_exact(&mut self, mut buf: &mut [u8]) -> Result<(), ContainerError> {
        debug_assert!(self.read + buf.len() as u64 <= self.raw_len);
        while !buf.is_empty() {
            match self.read_some(buf)? {
                0 => return Err(wrong_length(self.read, self.raw_len)),
                n => buf = &mut buf[n..],
            }
        }
        Ok(())
    }

    /// Checks that the payload ends after the R bytes read, as a complete frame.
    pub fn finish(mut self) -> Result<(), ContainerError> {
        // Reading on past R makes the decoder check the frame's end, and shows a longer payload.
        self.read_some(&mut [0])?;
        check_decompressed(self.read, self.raw_len)
    }

    fn read_some(&mut self, buf: &mut [u8]) -> Result<usize, ContainerError> {
        loop {
            match self.decoder.read(buf) {
                Ok(n) => {
                    self.read += n as u64;
                    return Ok(n);
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(undecompressed(e)),
            }
        }
    }
}

/// The magic number that opens a zstd frame (RFC 8878, section 3.1.1), as stored.
const ZSTD_MAGIC: [u8; 4] = [0x28, 0xB5, 0x2F, 0xFD];

#[cfg(test)]
mod tests {
    use super::*;

    const MAGIC: &[u8; 8] = b"\x89TEST\r\n\x1a";

    #[test]
    fn round_trip_and_layout() {
        let bytes = write(MAGIC, 1, 2, b"head", b"payload payload payload").unwrap();
        assert_eq!(&bytes[..8], MAGIC);
        assert_eq!(u16_at(&bytes, 8), 1);
        assert_eq!(u16_at(&bytes, 10), 2);
        assert_eq!(u32_at(&bytes, 12), 4);
        assert_eq!(u64_at(&bytes, 16), 23);
        assert_eq!(&bytes[32..36], b"head");
        let c = read(&bytes, MAGIC, "test", 1).unwrap();
        assert_eq!(
            (c.minor, c.header.as_slice(), c.payload.as_slice()),
            (2, &b"head"[..], &b"payload payload payload"[..])
        );
    }

    #[test]
    fn every_truncation_and_every_flipped_byte_is_an_error() {
        let bytes = write(MAGIC, 1, 0, b"head", &[7u8; 100]).unwrap();
        for n in 0..bytes.len() {
            assert!(
                read(&bytes[..n], MAGIC, "test", 1).is_err(),
                "truncated to {n}"
            );
        }
        for i in 0..bytes.len() {
            let mut b = bytes.clone();
            b[i] ^= 0x10;
            assert!(read(&b, MAGIC, "test", 1).is_err(), "flipped byte {i}");
        }
    }

    /// A container around `frames` as its payload, with a correct checksum.
    fn with_payload(frames: &[u8], raw_len: u64) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&1u16.to_le_bytes());
        out.extend_from_slice(&0u16.to_le_bytes());
        out.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(&raw_len.to_le_bytes());
        out.extend_from_slice(&(frames.len() as u64).to_le_bytes());
        out.extend_from_slice(frames);
        let crc = crc32fast::hash(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        out
    }

    #[test]
    fn a_payload_of_more_than_one_frame_is_refused() {
        let one = zstd::bulk::compress(b"abcd", 9).unwrap();
        assert!(read(&with_payload(&one, 4), MAGIC, "test", 1).is_ok());
        let two = [one.clone(), one.clone()].concat();
        let e = read(&with_payload(&two, 8), MAGIC, "test", 1).unwrap_err();
        assert!(
            e.to_string().contains("follow the payload's zstd frame"),
            "{e}"
        );
        // A skippable frame (magic 0x184D2A50) after the data frame, and before it.
        let skippable = [&[0x50, 0x2A, 0x4D, 0x18], &4u32.to_le_bytes()[..], b"junk"].concat();
        let after = [one.clone(), skippable.clone()].concat();
        assert!(read(&with_payload(&after, 4), MAGIC, "test", 1).is_err());
        let before = [skippable, one].concat();
        assert!(read(&with_payload(&before, 4), MAGIC, "test", 1).is_err());
    }

    /// The payload read a piece at a time, or the error that stopped it.
    fn streamed(opened: &Opened, piece: usize) -> Result<Vec<u8>, ContainerError> {
        let mut stream = opened.payload_stream()?;
        let mut out = vec![0; opened.raw_len() as usize];
        for part in out.chunks_mut(piece) {
            stream.read_exact(part)?;
        }
        stream.finish()?;
        Ok(out)
    }

    /// Streaming gives the payload, and refuses a damaged frame with `payload`'s own error.
    #[test]
    fn a_streamed_payload_is_the_payload_and_fails_alike() {
        let payload: Vec<u8> = (0..3000u32).map(|i| (i * i % 251) as u8).collect();
        let frame = zstd::bulk::compress(&payload, 9).unwrap();
        let bytes = with_payload(&frame, 3000);
        let opened = open(&bytes, MAGIC, "test", 1).unwrap();
        assert_eq!(streamed(&opened, 700).unwrap(), payload);
        let mut refused = 0;
        for i in 0..frame.len() {
            let mut damaged = frame.clone();
            damaged[i] ^= 0x10;
            let bytes = with_payload(&damaged, 3000);
            let opened = open(&bytes, MAGIC, "test", 1).unwrap();
            let whole = opened.payload();
            assert_eq!(streamed(&opened, 700), whole, "flipped byte {i}");
            refused += whole.is_err() as usize;
        }
        assert!(refused > 0);
    }

    #[test]
    fn frames_record_their_content_size_and_no_checksum() {
        let bytes = write(MAGIC, 1, 0, b"", &[1u8; 1000]).unwrap();
        let frame = &bytes[PREAMBLE..bytes.len() - 4];
        // Frame header descriptor (RFC 8878 3.1.1.1.1): the checksum flag is bit 2.
        assert_eq!(frame[4] & 0b100, 0);
        assert_eq!(
            zstd::zstd_safe::get_frame_content_size(frame).unwrap(),
            Some(1000)
        );
    }

    #[test]
    fn newer_major_version_is_refused_with_advice() {
        let bytes = write(MAGIC, 2, 0, b"", b"").unwrap();
        let e = read(&bytes, MAGIC, "test", 1).unwrap_err();
        assert_eq!(
            e,
            ContainerError::Version {
                format: "test",
                major: 2,
                minor: 0,
                supported: 1
            }
        );
        assert!(e.to_string().contains("newer"));
        let bytes = write(MAGIC, 0, 3, b"", b"").unwrap();
        let e = read(&bytes, MAGIC, "test", 1).unwrap_err().to_string();
        assert!(e.contains("0.3 is older"), "{e}");
    }
}
