//! Identities that another build must not match: this build's code, and the 64-bit hash that
//! keys cache entries, resumable renders and `converge`'s reused renders.

/// The identity of this build's code: a hash of the sources that make the cache's entries
/// (build.rs). It keys every entry, so a new build never reads what an older one made.
pub const CODE_ID: &str = env!("DUALHAIR_CODE_ID");

/// 64-bit FNV-1a (Fowler, Noll, Vo): stable across platforms and compiler versions.
#[derive(Clone, Copy)]
pub struct Fnv(pub u64);

impl Fnv {
    /// The hash of nothing (FNV-1a's offset basis).
    pub const START: Fnv = Fnv(0xcbf2_9ce4_8422_2325);

    /// A hash that starts from this build's [`CODE_ID`]: for fingerprints that another build
    /// must not match (resumable renders, `converge`'s reused renders).
    pub fn of_code() -> Fnv {
        Fnv::START.bytes(CODE_ID.as_bytes())
    }

    pub fn bytes(mut self, bytes: &[u8]) -> Fnv {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
        self
    }
}
