//! Base64 (RFC 4648, §4: standard alphabet, `=` padding) of the inline binary
//! `DataArray`s of a `.vtu` file: a streaming encoder for the writer and a decoder for the
//! checks that read tlsmpm's own files back.

/// Encode `bytes` as base64 (RFC 4648 §4: standard alphabet `A–Z a–z 0–9 + /`, `=` padding,
/// no line breaks); the result has `4 * ceil(len / 3)` characters.
///
/// ```
/// use tlsmpm::output::vtu::encode_base64;
/// assert_eq!(encode_base64(b"foobar"), "Zm9vYmFy");
/// assert_eq!(encode_base64(b"fo"), "Zm8=");
/// ```
pub fn encode_base64(bytes: &[u8]) -> String {
    let mut out = Vec::with_capacity(bytes.len().div_ceil(3) * 4);
    let mut encoder = Base64Encoder::new(&mut out);
    encoder.push(bytes);
    encoder.finish();
    out.into_iter().map(char::from).collect()
}

/// Decode base64 text (RFC 4648 §4: standard alphabet, `=` padding), ignoring ASCII
/// whitespace anywhere in the text.
///
/// Every group of four characters gives three bytes, `xxxxxx|xx xxxx|xxxx xx|xxxxxx`; a
/// final group `ab==` gives one byte and `abc=` two. Returns `None` for a character outside
/// the alphabet, a character count (without whitespace) that is not a multiple of four,
/// misplaced padding, or data after a padded group.
///
/// ```
/// use tlsmpm::output::vtu::decode_base64;
/// assert_eq!(decode_base64("Zm9v YmE=").as_deref(), Some(&b"fooba"[..]));
/// assert_eq!(decode_base64("Zm9"), None);
/// ```
pub fn decode_base64(text: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let mut quad = [0u8; 4];
    let mut filled = 0;
    let mut finished = false;
    for &ch in text.as_bytes() {
        if ch.is_ascii_whitespace() {
            continue;
        }
        if finished {
            return None;
        }
        quad[filled] = ch;
        filled += 1;
        if filled < 4 {
            continue;
        }
        filled = 0;
        let padding = match (quad[2], quad[3]) {
            (b'=', b'=') => 2,
            (b'=', _) => return None,
            (_, b'=') => 1,
            _ => 0,
        };
        let s0 = sextet(quad[0])?;
        let s1 = sextet(quad[1])?;
        let s2 = if padding >= 2 { 0 } else { sextet(quad[2])? };
        let s3 = if padding >= 1 { 0 } else { sextet(quad[3])? };
        let word = (s0 << 18) | (s1 << 12) | (s2 << 6) | s3;
        out.push((word >> 16) as u8);
        if padding < 2 {
            out.push((word >> 8) as u8);
        }
        if padding < 1 {
            out.push(word as u8);
        }
        finished = padding > 0;
    }
    (filled == 0).then_some(out)
}

pub(super) const BASE64_ALPHABET: &[u8; 64] =
    b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Bytes staged before encoding (a multiple of 3, so only the final block needs padding).
pub(super) const STAGE_BYTES: usize = 3 * 1024;

/// Streaming base64 encoder: bytes pushed in any chunking are staged in a small fixed
/// buffer and encoded in whole 3-byte blocks straight into `out`; [`Self::finish`] encodes
/// the last 1 or 2 bytes with `=` padding. The output equals the one-shot encoding of the
/// concatenation of all pushed bytes.
pub(super) struct Base64Encoder<'o> {
    out: &'o mut Vec<u8>,
    stage: [u8; STAGE_BYTES],
    staged: usize,
}

impl<'o> Base64Encoder<'o> {
    pub(super) fn new(out: &'o mut Vec<u8>) -> Self {
        Base64Encoder {
            out,
            stage: [0; STAGE_BYTES],
            staged: 0,
        }
    }

    pub(super) fn push(&mut self, mut bytes: &[u8]) {
        while !bytes.is_empty() {
            let take = (STAGE_BYTES - self.staged).min(bytes.len());
            let (head, tail) = bytes.split_at(take);
            self.stage[self.staged..self.staged + take].copy_from_slice(head);
            self.staged += take;
            bytes = tail;
            if self.staged == STAGE_BYTES {
                encode_blocks(self.out, &self.stage);
                self.staged = 0;
            }
        }
    }

    pub(super) fn finish(self) {
        let whole = self.staged / 3 * 3;
        encode_blocks(self.out, &self.stage[..whole]);
        let sym = |v: u8| BASE64_ALPHABET[usize::from(v & 63)];
        match self.stage[whole..self.staged] {
            [a] => self
                .out
                .extend_from_slice(&[sym(a >> 2), sym(a << 4), b'=', b'=']),
            [a, b] => self.out.extend_from_slice(&[
                sym(a >> 2),
                sym((a << 4) | (b >> 4)),
                sym(b << 2),
                b'=',
            ]),
            _ => {}
        }
    }
}

/// Encode whole 3-byte blocks (`bytes.len()` must be a multiple of 3; a remainder is
/// ignored).
pub(super) fn encode_blocks(out: &mut Vec<u8>, bytes: &[u8]) {
    for block in bytes.chunks_exact(3) {
        let word = (u32::from(block[0]) << 16) | (u32::from(block[1]) << 8) | u32::from(block[2]);
        out.extend_from_slice(&[
            BASE64_ALPHABET[(word >> 18) as usize & 63],
            BASE64_ALPHABET[(word >> 12) as usize & 63],
            BASE64_ALPHABET[(word >> 6) as usize & 63],
            BASE64_ALPHABET[word as usize & 63],
        ]);
    }
}

/// Value of one base64 symbol, `None` outside the alphabet (including `=`).
pub(super) fn sextet(ch: u8) -> Option<u32> {
    let value = match ch {
        b'A'..=b'Z' => ch - b'A',
        b'a'..=b'z' => ch - b'a' + 26,
        b'0'..=b'9' => ch - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => return None,
    };
    Some(u32::from(value))
}
