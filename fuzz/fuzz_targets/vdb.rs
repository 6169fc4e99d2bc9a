#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    volga_fuzz::harness().vdb(data);
});
