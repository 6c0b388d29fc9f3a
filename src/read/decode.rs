//! Binary payloads of VTU DataArrays: base64, block compression, byte order, scalar types.
//!
//! A binary payload is `header ‖ data` (VTK XML file format, "binary" and "appended" modes):
//!
//! - uncompressed: `header = [nbytes]`, then `nbytes` bytes of data;
//! - compressed: `header = [nblocks, block_size, last_block_size, csize_0 … csize_{nblocks-1}]`,
//!   then the compressed blocks back to back; `last_block_size = 0` means the last block is full.
//!
//! Header integers are `header_type` (UInt32 or UInt64) in the file's `byte_order`. Inline
//! payloads are base64; writers differ in whether header and data are encoded as one base64
//! string or as two (meshio and VTK do not agree), so the base64 decoder accepts padding in the
//! middle of the text and decodes each padded segment on its own.
//!
//! Memory is bounded by the declared sizes, never by what a block would inflate to: every block
//! inflates into a buffer of exactly its declared size and a block that would produce more is an
//! error. Declared sizes are checked against the compressed bytes present in the file
//! ([`max_ratio`]) before anything is allocated.

use std::borrow::Cow;
use std::io::Write;

use base64::Engine;
use base64::alphabet;
use base64::engine::{DecodePaddingMode, GeneralPurpose, GeneralPurposeConfig};
use rayon::prelude::*;

/// A decoding failure, described for the user; the caller adds the file and the array.
pub type DecodeResult<T> = std::result::Result<T, String>;

/// The numeric types of VTK XML DataArrays.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Scalar {
    Int8,
    UInt8,
    Int16,
    UInt16,
    Int32,
    UInt32,
    Int64,
    UInt64,
    Float32,
    Float64,
}

impl Scalar {
    /// Parses the `type` attribute of a DataArray (including VTK's legacy `Int`/`Float` names).
    pub fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "Int8" | "Char" => Scalar::Int8,
            "UInt8" | "UnsignedChar" => Scalar::UInt8,
            "Int16" | "Short" => Scalar::Int16,
            "UInt16" | "UnsignedShort" => Scalar::UInt16,
            "Int32" | "Int" => Scalar::Int32,
            "UInt32" | "UnsignedInt" => Scalar::UInt32,
            "Int64" | "Long" | "IdType" => Scalar::Int64,
            "UInt64" | "UnsignedLong" => Scalar::UInt64,
            "Float32" | "Float" => Scalar::Float32,
            "Float64" | "Double" => Scalar::Float64,
            _ => return None,
        })
    }

    /// Bytes per value.
    pub fn size(self) -> usize {
        match self {
            Scalar::Int8 | Scalar::UInt8 => 1,
            Scalar::Int16 | Scalar::UInt16 => 2,
            Scalar::Int32 | Scalar::UInt32 | Scalar::Float32 => 4,
            Scalar::Int64 | Scalar::UInt64 | Scalar::Float64 => 8,
        }
    }

    /// Whether values of this type are integers.
    pub fn is_integer(self) -> bool {
        !matches!(self, Scalar::Float32 | Scalar::Float64)
    }

    /// The VTK name of the type.
    pub fn name(self) -> &'static str {
        match self {
            Scalar::Int8 => "Int8",
            Scalar::UInt8 => "UInt8",
            Scalar::Int16 => "Int16",
            Scalar::UInt16 => "UInt16",
            Scalar::Int32 => "Int32",
            Scalar::UInt32 => "UInt32",
            Scalar::Int64 => "Int64",
            Scalar::UInt64 => "UInt64",
            Scalar::Float32 => "Float32",
            Scalar::Float64 => "Float64",
        }
    }
}

/// The `compressor` attribute of the VTKFile element.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compressor {
    None,
    Zlib,
    Lz4,
    Lzma,
}

impl Compressor {
    /// Parses the VTK class name of the compressor.
    pub fn parse(name: &str) -> Option<Compressor> {
        Some(match name {
            "" => Compressor::None,
            "vtkZLibDataCompressor" => Compressor::Zlib,
            "vtkLZ4DataCompressor" => Compressor::Lz4,
            "vtkLZMADataCompressor" => Compressor::Lzma,
            _ => return None,
        })
    }

    /// The name shown to users.
    pub fn name(self) -> &'static str {
        match self {
            Compressor::None => "none",
            Compressor::Zlib => "zlib",
            Compressor::Lz4 => "lz4",
            Compressor::Lzma => "lzma",
        }
    }
}

/// How the binary payloads of one file are laid out.
#[derive(Clone, Copy, Debug)]
pub struct Layout {
    /// Header integers are UInt64 (else UInt32).
    pub header_u64: bool,
    pub big_endian: bool,
    pub compressor: Compressor,
}

impl Layout {
    fn header_size(&self) -> usize {
        if self.header_u64 { 8 } else { 4 }
    }

    fn header_int(&self, bytes: &[u8], index: usize) -> DecodeResult<u64> {
        let size = self.header_size();
        let at = index * size;
        let raw = bytes
            .get(at..at + size)
            .ok_or_else(|| "binary header is cut short (truncated data)".to_string())?;
        Ok(match (self.header_u64, self.big_endian) {
            (true, false) => u64::from_le_bytes(raw.try_into().unwrap_or_default()),
            (true, true) => u64::from_be_bytes(raw.try_into().unwrap_or_default()),
            (false, false) => u32::from_le_bytes(raw.try_into().unwrap_or_default()) as u64,
            (false, true) => u32::from_be_bytes(raw.try_into().unwrap_or_default()) as u64,
        })
    }
}

/// The largest ratio of decoded to compressed size that a compressor can reach, with margin.
/// Declared sizes beyond `ratio × compressed bytes` cannot be honest, so they are refused before
/// any allocation. (zlib's deflate tops out at 1032:1, LZ4 at about 255:1; LZMA's ratio has no
/// small bound, so a generous one is used.)
pub fn max_ratio(compressor: Compressor) -> u64 {
    match compressor {
        Compressor::None => 1,
        Compressor::Zlib => 1100,
        Compressor::Lz4 => 300,
        Compressor::Lzma => 20_000,
    }
}

/// A hard cap on the decoded size of one array (16 GiB), whatever the file declares.
pub const MAX_ARRAY_BYTES: u64 = 16 << 30;

const BASE64: GeneralPurpose = GeneralPurpose::new(
    &alphabet::STANDARD,
    GeneralPurposeConfig::new()
        .with_decode_allow_trailing_bits(true)
        .with_decode_padding_mode(DecodePaddingMode::Indifferent),
);

/// Decodes base64 text that may contain whitespace and several padded segments
/// (`"AAAAAA==" + "…"`), returning the concatenation of the decoded segments. Long segments
/// are decoded in parallel pieces of whole 4-character groups.
pub fn base64_decode(text: &[u8]) -> DecodeResult<Vec<u8>> {
    let text = text.trim_ascii();
    let compact: Cow<[u8]> = if text.iter().any(u8::is_ascii_whitespace) {
        Cow::Owned(
            text.iter()
                .copied()
                .filter(|c| !c.is_ascii_whitespace())
                .collect(),
        )
    } else {
        Cow::Borrowed(text)
    };
    let mut out = vec![0u8; compact.len() / 4 * 3 + 3];
    let mut written = 0;
    let mut rest: &[u8] = &compact;
    while !rest.is_empty() {
        // A segment ends after a run of '=' padding (or at the end of the text).
        let end = match memchr::memchr(b'=', rest) {
            Some(p) => p + rest[p..].iter().take_while(|&&c| c == b'=').count(),
            None => rest.len(),
        };
        written += decode_segment(&rest[..end], &mut out[written..])?;
        rest = &rest[end..];
    }
    out.truncate(written);
    Ok(out)
}

/// Decodes one base64 segment (padding only at its end) into `out`, returning the length.
fn decode_segment(seg: &[u8], out: &mut [u8]) -> DecodeResult<usize> {
    const PIECE: usize = 1 << 20; // characters, a multiple of 4
    let bad = |e: base64::DecodeSliceError| format!("invalid base64 data: {e}");
    if seg.len() <= PIECE {
        return BASE64.decode_slice(seg, out).map_err(bad);
    }
    let lengths: Vec<usize> = seg
        .par_chunks(PIECE)
        .zip(out.par_chunks_mut(PIECE / 4 * 3))
        .map(|(text, dst)| BASE64.decode_slice(text, dst).map_err(bad))
        .collect::<DecodeResult<_>>()?;
    Ok(lengths.iter().sum())
}

/// A parsed `header ‖ data` payload: where the data bytes are, before any inflation.
#[derive(Debug)]
pub enum Payload<'a> {
    /// Uncompressed data.
    Raw(&'a [u8]),
    /// Compressed blocks that inflate to `block_size` bytes each (the last one possibly
    /// fewer), `total` bytes in all.
    Blocks {
        compressor: Compressor,
        block_size: usize,
        total: usize,
        blocks: Vec<&'a [u8]>,
    },
}

impl Payload<'_> {
    /// Decoded size in bytes.
    pub fn len(&self) -> usize {
        match self {
            Payload::Raw(b) => b.len(),
            Payload::Blocks { total, .. } => *total,
        }
    }

    /// Whether the payload holds no data.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Decodes into `dst`, which must be exactly [`Payload::len`] bytes long; blocks inflate in
    /// parallel, each into its own part of `dst`.
    pub fn decode_into(&self, dst: &mut [u8]) -> DecodeResult<()> {
        debug_assert_eq!(dst.len(), self.len());
        match self {
            Payload::Raw(b) => {
                dst.copy_from_slice(b);
                Ok(())
            }
            Payload::Blocks {
                compressor,
                block_size,
                blocks,
                ..
            } => dst
                .par_chunks_mut((*block_size).max(1))
                .zip(blocks.par_iter())
                .enumerate()
                .try_for_each(|(i, (d, src))| {
                    inflate(*compressor, src, d).map_err(|e| format!("block {i}: {e}"))
                }),
        }
    }

    /// The decoded bytes, borrowed when nothing needs inflating.
    pub fn bytes(&self) -> DecodeResult<Cow<'_, [u8]>> {
        match self {
            Payload::Raw(b) => Ok(Cow::Borrowed(b)),
            Payload::Blocks { total, .. } => {
                let mut out = vec![0u8; *total];
                self.decode_into(&mut out)?;
                Ok(Cow::Owned(out))
            }
        }
    }
}

/// Parses the header of one `header ‖ data` payload at the start of `bytes`. `expected_bytes`,
/// when known from the declared counts, must equal the decoded size; otherwise the header's size
/// is taken, bounded by the bytes present in the file. Nothing is allocated for the data here.
pub fn payload<'a>(
    bytes: &'a [u8],
    layout: &Layout,
    expected_bytes: Option<u64>,
) -> DecodeResult<Payload<'a>> {
    let hs = layout.header_size();
    match layout.compressor {
        Compressor::None => {
            let n = layout.header_int(bytes, 0)?;
            if let Some(e) = expected_bytes
                && e != n
            {
                return Err(format!(
                    "header declares {n} bytes of data but the declared counts need {e}"
                ));
            }
            let available = (bytes.len() - hs) as u64;
            if n > available {
                return Err(format!(
                    "header declares {n} bytes of data but only {available} remain in the file \
                     (truncated data or offset past the end)"
                ));
            }
            Ok(Payload::Raw(&bytes[hs..hs + n as usize]))
        }
        compressor => {
            let nblocks = layout.header_int(bytes, 0)?;
            let block_size = layout.header_int(bytes, 1)?;
            let last_size = layout.header_int(bytes, 2)?;
            let header_len = 3u64
                .checked_add(nblocks)
                .and_then(|n| n.checked_mul(hs as u64))
                .filter(|&n| n <= bytes.len() as u64)
                .ok_or_else(|| {
                    format!(
                        "compression header declares {nblocks} blocks, more than the file can hold"
                    )
                })? as usize;
            let total = if nblocks == 0 {
                0
            } else {
                let last = if last_size == 0 {
                    block_size
                } else {
                    last_size
                };
                if last > block_size {
                    return Err(format!(
                        "compression header: last block size {last} exceeds block size {block_size}"
                    ));
                }
                (nblocks - 1)
                    .checked_mul(block_size)
                    .and_then(|t| t.checked_add(last))
                    .ok_or_else(|| "compression header sizes overflow".to_string())?
            };
            if let Some(e) = expected_bytes
                && e != total
            {
                return Err(format!(
                    "compression header declares {total} bytes of data but the declared counts \
                     need {e}"
                ));
            }
            let mut blocks = Vec::with_capacity(nblocks as usize);
            let mut at = header_len;
            let mut sum = 0u64;
            for b in 0..nblocks as usize {
                let c = layout.header_int(bytes, 3 + b)?;
                sum = sum.saturating_add(c);
                if sum > (bytes.len() - header_len) as u64 {
                    return Err(format!(
                        "compressed blocks declare more bytes than the {} that remain in the \
                         file (truncated data or offset past the end)",
                        bytes.len() - header_len
                    ));
                }
                blocks.push(&bytes[at..at + c as usize]);
                at += c as usize;
            }
            let bound = sum
                .saturating_mul(max_ratio(compressor))
                .saturating_add(1 << 16)
                .min(MAX_ARRAY_BYTES);
            if total > bound {
                return Err(format!(
                    "compressed data of {sum} bytes claims to inflate to {total} bytes, more than \
                     {} can produce (limit {bound})",
                    compressor.name()
                ));
            }
            Ok(Payload::Blocks {
                compressor,
                block_size: block_size as usize,
                total: total as usize,
                blocks,
            })
        }
    }
}

/// Inflates one compressed block into `dst`, which has exactly the declared size.
fn inflate(compressor: Compressor, src: &[u8], dst: &mut [u8]) -> DecodeResult<()> {
    match compressor {
        Compressor::None => Err("not compressed".into()),
        Compressor::Zlib => {
            let mut z = flate2::Decompress::new(true);
            let status = z
                .decompress(src, dst, flate2::FlushDecompress::Finish)
                .map_err(|e| format!("corrupt zlib data ({e})"))?;
            let produced = z.total_out() as usize;
            if status != flate2::Status::StreamEnd {
                if produced == dst.len() {
                    let mut probe = [0u8; 1];
                    let before = z.total_out();
                    let _ = z.decompress(
                        &src[z.total_in() as usize..],
                        &mut probe,
                        flate2::FlushDecompress::Finish,
                    );
                    if z.total_out() > before {
                        return Err(format!(
                            "zlib block inflates past its declared size of {} bytes",
                            dst.len()
                        ));
                    }
                }
                return Err(format!(
                    "zlib block is truncated or corrupt: {produced} of {} bytes inflated",
                    dst.len()
                ));
            }
            if produced != dst.len() {
                return Err(format!(
                    "zlib block inflates to {produced} bytes, declared {}",
                    dst.len()
                ));
            }
            Ok(())
        }
        Compressor::Lz4 => {
            let n = lz4_flex::block::decompress_into(src, dst)
                .map_err(|e| format!("corrupt or oversized lz4 block ({e})"))?;
            if n != dst.len() {
                return Err(format!(
                    "lz4 block inflates to {n} bytes, declared {}",
                    dst.len()
                ));
            }
            Ok(())
        }
        Compressor::Lzma => {
            // lzma-rs accumulates a whole xz block in memory before writing it out, so the
            // SliceWriter alone cannot stop a bomb: the chunk headers are summed first.
            let unpacked = xz_unpacked_size(src)?;
            if unpacked > dst.len() as u64 {
                return Err(format!(
                    "lzma block inflates past its declared size ({unpacked} bytes, declared {})",
                    dst.len()
                ));
            }
            let mut w = SliceWriter { dst, pos: 0 };
            let mut input = src;
            lzma_rs::xz_decompress(&mut input, &mut w).map_err(|e| match e {
                lzma_rs::error::Error::IoError(io)
                    if io.kind() == std::io::ErrorKind::WriteZero =>
                {
                    "lzma block inflates past its declared size".to_string()
                }
                e => format!("corrupt lzma data ({e})"),
            })?;
            if w.pos != w.dst.len() {
                return Err(format!(
                    "lzma block inflates to {} bytes, declared {}",
                    w.pos,
                    w.dst.len()
                ));
            }
            Ok(())
        }
    }
}

/// The number of bytes an xz stream inflates to, read from its LZMA2 chunk headers without
/// decoding anything (xz file format 1.0.4 §3; LZMA2 chunk headers as read by lzma-rs 0.3).
///
/// Each LZMA2 chunk declares its unpacked size: control byte `1`/`2` is an uncompressed chunk of
/// `u16_be + 1` bytes; control `c ≥ 0x80` is an LZMA chunk of `((c & 0x1f) << 16 | u16_be) + 1`
/// bytes, followed by `u16_be + 1` packed bytes (and a properties byte when `(c >> 5) & 3 ≥ 2`);
/// `0` ends the block. Blocks with more than one filter are refused: lzma-rs would run the
/// second filter over the first one's output, which no chunk header bounds.
pub fn xz_unpacked_size(src: &[u8]) -> DecodeResult<u64> {
    let corrupt = |what: &str| format!("corrupt lzma data ({what})");
    let byte = |at: usize| src.get(at).copied().ok_or_else(|| corrupt("truncated"));
    let u16_be =
        |at: usize| -> DecodeResult<u64> { Ok(((byte(at)? as u64) << 8) | byte(at + 1)? as u64) };
    if src.len() < 12 || &src[..6] != b"\xFD7zXZ\x00" {
        return Err(corrupt("no xz stream header"));
    }
    // The check methods lzma-rs knows: none, CRC32, CRC64, SHA-256.
    let check_size = match src[7] {
        0x00 => 0,
        0x01 => 4,
        0x04 => 8,
        0x0a => 32,
        _ => return Err(corrupt("unknown check method")),
    };
    let mut at = 12;
    let mut total = 0u64;
    loop {
        let block_start = at;
        let size_byte = byte(at)?;
        if size_byte == 0 {
            return Ok(total); // the index follows: no more blocks
        }
        let flags = byte(at + 1)?;
        if flags & 0x03 != 0 {
            return Err(corrupt("more than one filter in a block"));
        }
        at += (size_byte as usize + 1) * 4;
        loop {
            let control = byte(at)?;
            at += 1;
            match control {
                0 => break,
                1 | 2 => {
                    let n = u16_be(at)? + 1;
                    total += n;
                    at += 2 + n as usize;
                }
                0x80..=0xff => {
                    total += ((((control & 0x1f) as u64) << 16) | u16_be(at)?) + 1;
                    let packed = u16_be(at + 2)? + 1;
                    let props = usize::from((control >> 5) & 3 >= 2);
                    at += 4 + props + packed as usize;
                }
                _ => return Err(corrupt("invalid LZMA2 chunk")),
            }
        }
        // Block padding to a multiple of four bytes, then the check.
        at += (4 - (at - block_start) % 4) % 4 + check_size;
    }
}

/// A writer into a fixed slice that refuses to grow: decompression can never exceed it.
struct SliceWriter<'a> {
    dst: &'a mut [u8],
    pos: usize,
}

impl Write for SliceWriter<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let room = self.dst.len() - self.pos;
        if buf.len() > room {
            return Err(std::io::Error::new(
                std::io::ErrorKind::WriteZero,
                "past declared size",
            ));
        }
        self.dst[self.pos..self.pos + buf.len()].copy_from_slice(buf);
        self.pos += buf.len();
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Numbers a DataArray can be converted to.
pub trait Number: Copy + Send + Sync + Default + 'static {
    fn from_f64(v: f64) -> Self;
    fn from_i64(v: i64) -> Self;
    fn from_u64(v: u64) -> Self;
}

impl Number for f64 {
    fn from_f64(v: f64) -> Self {
        v
    }
    fn from_i64(v: i64) -> Self {
        v as f64
    }
    fn from_u64(v: u64) -> Self {
        v as f64
    }
}

impl Number for i64 {
    fn from_f64(v: f64) -> Self {
        // Only used for integer-valued arrays; non-integers are refused by the caller.
        if v.fract() == 0.0 && v.abs() < 9.2e18 {
            v as i64
        } else {
            i64::MIN
        }
    }
    fn from_i64(v: i64) -> Self {
        v
    }
    fn from_u64(v: u64) -> Self {
        i64::try_from(v).unwrap_or(i64::MIN)
    }
}

macro_rules! convert_as {
    ($bytes:expr, $t:ty, $be:expr, $via:ident) => {{
        const N: usize = std::mem::size_of::<$t>();
        $bytes
            .par_chunks_exact(N)
            .with_min_len(1 << 12)
            .map(|c| {
                let a: [u8; N] = c.try_into().unwrap_or([0; N]);
                let v = if $be {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                };
                T::$via(v.into())
            })
            .collect::<Vec<T>>()
    }};
}

/// Converts raw data bytes of type `scalar` to numbers. `bytes.len()` must be a multiple of the
/// type size (checked).
pub fn convert<T: Number>(bytes: &[u8], scalar: Scalar, big_endian: bool) -> DecodeResult<Vec<T>> {
    if !bytes.len().is_multiple_of(scalar.size()) {
        return Err(format!(
            "{} bytes of data is not a whole number of {} values",
            bytes.len(),
            scalar.name()
        ));
    }
    Ok(match scalar {
        Scalar::Int8 => convert_as!(bytes, i8, big_endian, from_i64),
        Scalar::UInt8 => convert_as!(bytes, u8, big_endian, from_i64),
        Scalar::Int16 => convert_as!(bytes, i16, big_endian, from_i64),
        Scalar::UInt16 => convert_as!(bytes, u16, big_endian, from_i64),
        Scalar::Int32 => convert_as!(bytes, i32, big_endian, from_i64),
        Scalar::UInt32 => convert_as!(bytes, u32, big_endian, from_i64),
        Scalar::Int64 => convert_as!(bytes, i64, big_endian, from_i64),
        Scalar::UInt64 => convert_as!(bytes, u64, big_endian, from_u64),
        Scalar::Float32 => convert_as!(bytes, f32, big_endian, from_f64),
        Scalar::Float64 => convert_as!(bytes, f64, big_endian, from_f64),
    })
}

/// Parses whitespace-separated ASCII numbers. `expected`, when known, must equal the count.
pub fn parse_ascii<T: Number>(
    text: &[u8],
    scalar: Scalar,
    expected: Option<usize>,
) -> DecodeResult<Vec<T>> {
    let text = std::str::from_utf8(text).map_err(|_| "ASCII data is not valid text".to_string())?;
    // Each value needs at least one character and one separator, which bounds any allocation.
    let cap = expected.unwrap_or(0).min(text.len() / 2 + 1);
    let mut out = Vec::with_capacity(cap);
    for (i, token) in text.split_ascii_whitespace().enumerate() {
        let v = if scalar.is_integer() {
            match token.parse::<i64>() {
                Ok(v) => T::from_i64(v),
                Err(_) => match token.parse::<u64>() {
                    Ok(v) => T::from_u64(v),
                    Err(_) => {
                        return Err(format!(
                            "value {i} '{}' is not an integer",
                            crate::error::shorten(token)
                        ));
                    }
                },
            }
        } else {
            match token.parse::<f64>() {
                Ok(v) => T::from_f64(v),
                Err(_) => match token.to_ascii_lowercase().as_str() {
                    "nan" | "-nan" => T::from_f64(f64::NAN),
                    "inf" | "infinity" => T::from_f64(f64::INFINITY),
                    "-inf" | "-infinity" => T::from_f64(f64::NEG_INFINITY),
                    _ => {
                        return Err(format!(
                            "value {i} '{}' is not a number",
                            crate::error::shorten(token)
                        ));
                    }
                },
            }
        };
        if let Some(e) = expected
            && out.len() >= e
        {
            return Err(format!("more than the {e} values expected"));
        }
        out.push(v);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn b64(bytes: &[u8]) -> String {
        base64::engine::general_purpose::STANDARD.encode(bytes)
    }

    #[test]
    fn base64_with_padding_in_the_middle_decodes_each_segment() {
        let header = 8u32.to_le_bytes();
        let data: Vec<u8> = (1..=8).collect();
        let joined = format!("{}{}", b64(&header), b64(&data));
        assert!(joined[..8].ends_with("=="));
        let mut expect = header.to_vec();
        expect.extend_from_slice(&data);
        assert_eq!(base64_decode(joined.as_bytes()).unwrap(), expect);
        let spaced = format!("\n   {}\n  {}  \n", b64(&header), b64(&data));
        assert_eq!(base64_decode(spaced.as_bytes()).unwrap(), expect);
    }

    #[test]
    fn base64_garbage_is_an_error() {
        let e = base64_decode(b"AAAA!!!!").unwrap_err();
        assert!(e.starts_with("invalid base64 data"), "{e}");
    }

    fn zlib(bytes: &[u8]) -> Vec<u8> {
        let mut enc = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        enc.write_all(bytes).unwrap();
        enc.finish().unwrap()
    }

    fn compressed_payload(blocks: &[Vec<u8>], block_size: u64, last: u64) -> Vec<u8> {
        let mut p = Vec::new();
        for v in [blocks.len() as u64, block_size, last] {
            p.extend_from_slice(&v.to_le_bytes());
        }
        for b in blocks {
            p.extend_from_slice(&(b.len() as u64).to_le_bytes());
        }
        for b in blocks {
            p.extend_from_slice(b);
        }
        p
    }

    const ZLIB64: Layout = Layout {
        header_u64: true,
        big_endian: false,
        compressor: Compressor::Zlib,
    };

    #[test]
    fn zlib_blocks_with_partial_last_block() {
        let data: Vec<u8> = (0..2500u32).map(|i| (i % 251) as u8).collect();
        let blocks: Vec<Vec<u8>> = data.chunks(1000).map(zlib).collect();
        let p = compressed_payload(&blocks, 1000, 500);
        let parsed = payload(&p, &ZLIB64, Some(2500)).unwrap();
        let out = parsed.bytes().unwrap();
        assert_eq!(&out[..], &data[..]);
    }

    #[test]
    fn a_small_block_inflating_past_its_declared_size_is_refused() {
        let bomb = zlib(&vec![0u8; 1 << 20]);
        // Declares 1000 bytes for a block that inflates to 1 MiB.
        let p = compressed_payload(&[bomb], 1000, 0);
        let e = payload(&p, &ZLIB64, Some(1000))
            .unwrap()
            .bytes()
            .unwrap_err();
        assert_eq!(
            e,
            "block 0: zlib block inflates past its declared size of 1000 bytes"
        );
    }

    #[test]
    fn a_huge_declared_size_is_refused_before_allocation() {
        let tiny = zlib(&[0u8; 16]);
        let p = compressed_payload(std::slice::from_ref(&tiny), 5 << 30, 0);
        let e = payload(&p, &ZLIB64, None).unwrap_err();
        assert!(e.contains("claims to inflate to 5368709120 bytes"), "{e}");
    }

    #[test]
    fn big_endian_uncompressed_float64() {
        let vals = [1.5f64, -2.25, 1e300];
        let mut p = (24u32).to_be_bytes().to_vec();
        for v in vals {
            p.extend_from_slice(&v.to_be_bytes());
        }
        let layout = Layout {
            header_u64: false,
            big_endian: true,
            compressor: Compressor::None,
        };
        let parsed = payload(&p, &layout, Some(24)).unwrap();
        let bytes = parsed.bytes().unwrap();
        let got: Vec<f64> = convert(&bytes, Scalar::Float64, true).unwrap();
        assert_eq!(got, vals);
    }

    #[test]
    fn truncated_uncompressed_payload_is_refused() {
        let mut p = (24u32).to_le_bytes().to_vec();
        p.extend_from_slice(&[0u8; 10]);
        let layout = Layout {
            header_u64: false,
            big_endian: false,
            compressor: Compressor::None,
        };
        let e = payload(&p, &layout, None).unwrap_err();
        assert!(
            e.contains("declares 24 bytes of data but only 10 remain"),
            "{e}"
        );
    }

    #[test]
    fn lz4_and_lzma_blocks_round_trip() {
        let data: Vec<u8> = (0..3000u32).map(|i| (i * 7 % 13) as u8).collect();
        let lz4 = lz4_flex::block::compress(&data);
        let p = compressed_payload(&[lz4], 3000, 0);
        let layout = Layout {
            compressor: Compressor::Lz4,
            ..ZLIB64
        };
        assert_eq!(
            &payload(&p, &layout, Some(3000)).unwrap().bytes().unwrap()[..],
            &data[..]
        );

        let mut xz = Vec::new();
        lzma_rs::xz_compress(&mut &data[..], &mut xz).unwrap();
        let p = compressed_payload(&[xz], 3000, 0);
        let layout = Layout {
            compressor: Compressor::Lzma,
            ..ZLIB64
        };
        assert_eq!(
            &payload(&p, &layout, Some(3000)).unwrap().bytes().unwrap()[..],
            &data[..]
        );
    }

    /// An xz stream of 1 MiB declared as a 1000-byte block is refused from its chunk headers,
    /// before lzma-rs would inflate the whole block into its own buffer.
    #[test]
    fn an_lzma_block_inflating_past_its_declared_size_is_refused_before_decoding() {
        let big = vec![7u8; 1 << 20];
        let mut xz = Vec::new();
        lzma_rs::xz_compress(&mut &big[..], &mut xz).unwrap();
        assert_eq!(xz_unpacked_size(&xz).unwrap(), 1 << 20);
        let p = compressed_payload(&[xz], 1000, 0);
        let layout = Layout {
            compressor: Compressor::Lzma,
            ..ZLIB64
        };
        let e = payload(&p, &layout, Some(1000))
            .unwrap()
            .bytes()
            .unwrap_err();
        assert_eq!(
            e,
            "block 0: lzma block inflates past its declared size (1048576 bytes, declared 1000)"
        );
    }

    /// Chunk headers are summed exactly: a stream of LZMA2 chunks (uncompressed chunks of at
    /// most 64 KiB from lzma-rs) inflating to 200 000 bytes declares 200 000; a block header
    /// with two filters is refused.
    #[test]
    fn xz_chunk_headers_give_the_unpacked_size() {
        let data: Vec<u8> = (0..200_000u32).map(|i| (i % 97) as u8).collect();
        let mut xz = Vec::new();
        lzma_rs::xz_compress(&mut &data[..], &mut xz).unwrap();
        assert_eq!(xz_unpacked_size(&xz).unwrap(), 200_000);
        let mut two_filters = xz.clone();
        two_filters[13] |= 0x01; // block flags: number of filters − 1
        assert_eq!(
            xz_unpacked_size(&two_filters).unwrap_err(),
            "corrupt lzma data (more than one filter in a block)"
        );
        assert_eq!(
            xz_unpacked_size(&xz[..40]).unwrap_err(),
            "corrupt lzma data (truncated)"
        );
    }

    #[test]
    fn every_scalar_type_converts() {
        let cases: [(Scalar, Vec<u8>, f64); 10] = [
            (Scalar::Int8, (-5i8).to_le_bytes().to_vec(), -5.0),
            (Scalar::UInt8, 250u8.to_le_bytes().to_vec(), 250.0),
            (Scalar::Int16, (-300i16).to_le_bytes().to_vec(), -300.0),
            (Scalar::UInt16, 60000u16.to_le_bytes().to_vec(), 60000.0),
            (Scalar::Int32, (-70000i32).to_le_bytes().to_vec(), -70000.0),
            (Scalar::UInt32, 4_000_000_000u32.to_le_bytes().to_vec(), 4e9),
            (
                Scalar::Int64,
                (-(1i64 << 40)).to_le_bytes().to_vec(),
                -1099511627776.0,
            ),
            (
                Scalar::UInt64,
                (1u64 << 63).to_le_bytes().to_vec(),
                9223372036854775808.0,
            ),
            (
                Scalar::Float32,
                0.1f32.to_le_bytes().to_vec(),
                0.1f32 as f64,
            ),
            (Scalar::Float64, 0.1f64.to_le_bytes().to_vec(), 0.1),
        ];
        for (s, bytes, want) in cases {
            let got: Vec<f64> = convert(&bytes, s, false).unwrap();
            assert_eq!(got, vec![want], "{s:?}");
        }
        let e = convert::<f64>(&[0u8; 7], Scalar::Float32, false).unwrap_err();
        assert_eq!(e, "7 bytes of data is not a whole number of Float32 values");
    }

    #[test]
    fn conversion_of_long_arrays_keeps_order() {
        let vals: Vec<f64> = (0..100_003).map(|i| i as f64 * 0.5).collect();
        let bytes: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
        assert_eq!(
            convert::<f64>(&bytes, Scalar::Float64, false).unwrap(),
            vals
        );
        let ints: Vec<i64> = convert(&bytes[..8 * 5], Scalar::Int64, false).unwrap();
        assert_eq!(ints.len(), 5);
    }

    #[test]
    fn ascii_numbers_and_errors() {
        let v: Vec<f64> = parse_ascii(b" 1 -2.5e3\n nan 4 ", Scalar::Float64, Some(4)).unwrap();
        assert_eq!(v[..2], [1.0, -2500.0]);
        assert!(v[2].is_nan());
        let e = parse_ascii::<f64>(b"1 2 x", Scalar::Float32, None).unwrap_err();
        assert_eq!(e, "value 2 'x' is not a number");
        let e = parse_ascii::<i64>(b"1 2.5", Scalar::Int32, None).unwrap_err();
        assert_eq!(e, "value 1 '2.5' is not an integer");
        let e = parse_ascii::<f64>(b"1 2 3", Scalar::Float64, Some(2)).unwrap_err();
        assert_eq!(e, "more than the 2 values expected");
    }
}
