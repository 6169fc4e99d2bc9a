#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    volga_fuzz::harness().adf_build(data);
});
