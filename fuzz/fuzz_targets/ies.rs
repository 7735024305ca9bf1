//! IES LM-63 text through the parser, as the importer calls it (lossy UTF-8).
#![no_main]

use libfuzzer_sys::fuzz_target;
use penumbra_engine::ies::IesProfile;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let _ = IesProfile::parse(&text, "fuzz.ies");
});
