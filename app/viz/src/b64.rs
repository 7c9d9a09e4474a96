//! Base64 (standard alphabet, padded) for the page's binary payloads, by the
//! `base64` crate; `f32s` fixes the byte order the page reads.

use base64::Engine as _;
use base64::engine::general_purpose::STANDARD;

/// Encodes bytes.
pub fn bytes(data: &[u8]) -> String {
    STANDARD.encode(data)
}

/// Encodes `f32`s little-endian (what a JS `Float32Array` reads); infinities stay.
pub fn f32s(data: &[f32]) -> String {
    let raw: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
    bytes(&raw)
}

#[cfg(test)]
mod tests {
    #[test]
    fn rfc4648_vectors() {
        for (i, o) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(super::bytes(i.as_bytes()), o);
        }
    }
}
