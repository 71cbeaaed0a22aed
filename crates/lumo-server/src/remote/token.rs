//! The token a hub prints and every worker must present: 128 random bits from the operating
//! system, as 32 hex digits, compared in constant time.

/// Why a token was refused.
#[derive(Debug, thiserror::Error)]
pub enum TokenError {
    /// Too short, too long or not hex.
    #[error("a worker token is 32 to {max} hex digits (128 bits or more); got {len} characters{}", if *.hex { "" } else { ", not all hex" })]
    Format {
        /// Characters given.
        len: usize,
        /// True when every character is a hex digit.
        hex: bool,
        /// Most characters allowed.
        max: usize,
    },
    /// The operating system's random source failed.
    #[error("cannot draw a random token: {0}")]
    Random(String),
}

/// Hex digits of a drawn token (128 bits).
const DRAWN_DIGITS: usize = 32;

/// A new random token of 128 bits, as 32 lower-case hex digits.
pub fn new_token() -> Result<String, TokenError> {
    let mut bytes = [0u8; DRAWN_DIGITS / 2];
    getrandom::fill(&mut bytes).map_err(|e| TokenError::Random(e.to_string()))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// Checks a token given by the user: 32 to [`crate::protocol::remote::MAX_TOKEN`] hex digits.
pub fn check_token(token: &str) -> Result<(), TokenError> {
    let max = crate::protocol::remote::MAX_TOKEN;
    let hex = token.bytes().all(|b| b.is_ascii_hexdigit());
    if !hex || token.len() < DRAWN_DIGITS || token.len() > max {
        return Err(TokenError::Format {
            len: token.chars().count(),
            hex,
            max,
        });
    }
    Ok(())
}

/// `a == b` in time that depends only on the lengths, so a worker cannot find the token a
/// byte at a time by timing refusals.
pub(crate) fn same_token(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_are_random_hex_and_checked() {
        let (a, b) = (new_token().expect("token"), new_token().expect("token"));
        assert_eq!(a.len(), 32);
        assert!(check_token(&a).is_ok() && a != b);
        assert!(check_token("abc").is_err());
        assert!(check_token(&"g".repeat(32)).is_err());
        assert!(check_token(&"a".repeat(65)).is_err());
        assert!(same_token(&a, &a.clone()) && !same_token(&a, &b) && !same_token(&a, "a"));
    }
}
