//! Scenario TOML bytes through decoding, parsing, validation, transcription
//! setup and a short solve with both methods; a panic (from bellyflop or a
//! broken invariant) is a finding. See `bellyflop::fuzzing`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = bellyflop::fuzzing::exercise(data);
});
