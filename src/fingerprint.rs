//! The content hash that ties an MCMC image to the mask it was rendered with (DESIGN §5): the
//! renderer writes it into the MCMC header, the compositor recomputes it from the mask it is given
//! and warns when they differ, because eq. (2) is only right when both used the same α.

/// Header attribute holding the path of the mask an MCMC image was rendered with.
pub const MASK_PATH_ATTR: &str = "mixmc.mask";
/// Header attribute holding [`alpha_hash`] of that mask.
pub const MASK_HASH_ATTR: &str = "mixmc.mask_hash";

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;

/// 64-bit FNV-1a: simple enough for any other tool to reimplement, and a mask's exact bits decide
/// the estimate, so no tolerance is wanted.
pub fn fnv1a64(bytes: impl IntoIterator<Item = u8>) -> u64 {
    bytes
        .into_iter()
        .fold(FNV_OFFSET, |h, b| (h ^ b as u64).wrapping_mul(FNV_PRIME))
}

/// `fnv1a64:` and 16 hex digits of FNV-1a over the width and height (u32, little-endian) and then
/// the `alpha` channel's f32 bit patterns (little-endian, row-major): the size is included so a
/// constant mask of another resolution does not match.
pub fn alpha_hash(width: usize, height: usize, alpha: &[f32]) -> String {
    let size = [width as u32, height as u32]
        .into_iter()
        .flat_map(u32::to_le_bytes);
    let bits = alpha.iter().flat_map(|a| a.to_bits().to_le_bytes());
    format!("fnv1a64:{:016x}", fnv1a64(size.chain(bits)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_reference_values() {
        // Published FNV-1a 64 test vectors.
        assert_eq!(fnv1a64(*b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(*b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(*b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn hash_sees_values_and_size() {
        let a = alpha_hash(2, 2, &[0.1, 1.0, 0.1, 0.1]);
        assert_eq!(a, alpha_hash(2, 2, &[0.1, 1.0, 0.1, 0.1]));
        assert_ne!(a, alpha_hash(2, 2, &[0.1, 0.1, 1.0, 0.1]));
        assert_ne!(alpha_hash(4, 1, &[1.0; 4]), alpha_hash(2, 2, &[1.0; 4]));
        assert!(a.starts_with("fnv1a64:") && a.len() == 8 + 16);
    }
}
