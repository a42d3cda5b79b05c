//! Damaged copies of a good file, for the tests that every truncation and random corruption of a
//! file is refused or read cleanly: an error (naming the file, where there is one) or valid data,
//! never a panic, never an allocation out of proportion to the file.

use rand::Rng;
use rand_pcg::Pcg64;
use std::ops::RangeInclusive;

/// Calls `check(len, &good[..len])` for the file cut to every length below `dense` and from there
/// to every `step`-th length, up to but not including the whole file.
pub fn each_truncation(good: &[u8], dense: usize, step: usize, mut check: impl FnMut(usize, &[u8])) {
    let mut len = 0;
    while len < good.len() {
        check(len, &good[..len]);
        len += if len < dense { 1 } else { step };
    }
}

/// Calls `check(n, at, &copy)` for `count` copies of `good`, copy `n` with a number of random
/// bits flipped drawn from `flips` (no draw when it holds one number), `at` the byte of its last
/// flip. With `header`, each flip lands in the first `header` bytes half the time (where a flip
/// changes the meaning of everything after it), else anywhere. The copies follow from `rng`.
pub fn each_bit_flip(
    good: &[u8],
    rng: &mut Pcg64,
    count: usize,
    flips: RangeInclusive<usize>,
    header: Option<usize>,
    mut check: impl FnMut(usize, usize, &[u8]),
) {
    for n in 0..count {
        let mut b = good.to_vec();
        let times = if flips.start() == flips.end() { *flips.start() } else { rng.random_range(flips.clone()) };
        let mut at = 0;
        for _ in 0..times {
            at = match header {
                Some(header) if rng.random::<bool>() => rng.random_range(0..header),
                _ => rng.random_range(0..b.len()),
            };
            b[at] ^= 1 << rng.random_range(0..8);
        }
        check(n, at, &b);
    }
}

/// Calls `check(at, flip, &copy)` for copies of `good` with each byte in turn xor-ed with 0xff
/// and with one random bit of it (from `rng`).
pub fn each_byte_flipped(good: &[u8], rng: &mut Pcg64, mut check: impl FnMut(usize, u8, &[u8])) {
    for at in 0..good.len() {
        for flip in [0xffu8, 1 << rng.random_range(0..8)] {
            let mut b = good.to_vec();
            b[at] ^= flip;
            check(at, flip, &b);
        }
    }
}
