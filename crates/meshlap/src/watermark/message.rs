//! The watermark message: hexadecimal text ↔ bits.
//!
//! Hex digit `i` (case-insensitive) holds bits `4i … 4i+3`, most significant first, so
//! `"a5"` is `1,0,1,0, 0,1,0,1`. A 64-bit message is 16 hex digits; other lengths are
//! allowed (1 to [`MAX_BITS`] bits). A bit count that is not a multiple of 4 is printed
//! with the last digit padded by zero bits.

use serde::Serialize;

/// Longest message accepted, in bits.
pub const MAX_BITS: usize = 4096;

/// Errors of parsing or sizing a message.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MessageError {
    /// The text is empty.
    #[error("the message is empty; give at least one hex digit (e.g. 16 digits for 64 bits)")]
    Empty,
    /// A character is not a hex digit.
    #[error(
        "the message has a non-hex character {character:?} at position {position}; use 0-9 and a-f"
    )]
    NotHex {
        /// The character.
        character: char,
        /// Its position (0-based, in characters).
        position: usize,
    },
    /// More bits than [`MAX_BITS`].
    #[error("the message has {bits} bits; at most {max} are supported")]
    TooLong {
        /// Bits requested.
        bits: usize,
        /// The limit.
        max: usize,
    },
}

/// A message of `len()` bits.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Message {
    bits: Vec<bool>,
}

impl Message {
    /// Parses hexadecimal text (an optional `0x` prefix is allowed).
    pub fn from_hex(text: &str) -> Result<Self, MessageError> {
        let t = text.trim();
        let t = t
            .strip_prefix("0x")
            .or_else(|| t.strip_prefix("0X"))
            .unwrap_or(t);
        if t.is_empty() {
            return Err(MessageError::Empty);
        }
        let mut bits = Vec::with_capacity(4 * t.len());
        for (position, character) in t.chars().enumerate() {
            let d = character.to_digit(16).ok_or(MessageError::NotHex {
                character,
                position,
            })?;
            bits.extend((0..4).rev().map(|k| (d >> k) & 1 == 1));
        }
        Self::from_bits(bits)
    }

    /// A message from its bits (1 to [`MAX_BITS`]).
    pub fn from_bits(bits: Vec<bool>) -> Result<Self, MessageError> {
        if bits.is_empty() {
            return Err(MessageError::Empty);
        }
        if bits.len() > MAX_BITS {
            return Err(MessageError::TooLong {
                bits: bits.len(),
                max: MAX_BITS,
            });
        }
        Ok(Self { bits })
    }

    /// The bits.
    pub fn bits(&self) -> &[bool] {
        &self.bits
    }

    /// Number of bits.
    pub fn len(&self) -> usize {
        self.bits.len()
    }

    /// Always false (a message has at least one bit); for clippy's `len` rule.
    pub fn is_empty(&self) -> bool {
        self.bits.is_empty()
    }

    /// The bits as hexadecimal text (lower case, the last digit zero-padded).
    pub fn to_hex(&self) -> String {
        bits_to_hex(&self.bits)
    }
}

/// Bits as lower-case hexadecimal text, 4 bits per digit, the last digit zero-padded.
pub fn bits_to_hex(bits: &[bool]) -> String {
    bits.chunks(4)
        .map(|c| {
            let d = (0..4).fold(0u32, |acc, k| {
                (acc << 1) | u32::from(c.get(k).copied().unwrap_or(false))
            });
            char::from_digit(d, 16).unwrap_or('0')
        })
        .collect()
}

impl std::str::FromStr for Message {
    type Err = MessageError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::from_hex(s)
    }
}

impl std::fmt::Display for Message {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.to_hex())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_round_trips_and_orders_bits_msb_first() {
        let m = Message::from_hex("A5").unwrap();
        let b: Vec<u8> = m.bits().iter().map(|&x| u8::from(x)).collect();
        assert_eq!(b, [1, 0, 1, 0, 0, 1, 0, 1]);
        assert_eq!(m.to_hex(), "a5");
        let long = Message::from_hex("0x0123456789abcdef").unwrap();
        assert_eq!(long.len(), 64);
        assert_eq!(long.to_hex(), "0123456789abcdef");
        assert_eq!(bits_to_hex(&[true, true]), "c");
    }

    #[test]
    fn bad_text_gives_typed_errors() {
        assert_eq!(Message::from_hex(""), Err(MessageError::Empty));
        assert_eq!(Message::from_hex("0x"), Err(MessageError::Empty));
        assert_eq!(
            Message::from_hex("12g4"),
            Err(MessageError::NotHex {
                character: 'g',
                position: 2
            })
        );
        let long = "f".repeat(MAX_BITS / 4 + 1);
        assert!(matches!(
            Message::from_hex(&long),
            Err(MessageError::TooLong { .. })
        ));
        assert!(Message::from_bits(vec![]).is_err());
    }
}
