#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    volga_fuzz::harness().sculpt_file(data);
});
