#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = dualhair_fuzz::usd(data);
});
