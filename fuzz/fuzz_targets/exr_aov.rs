//! EXR ingestion as the mask, composite and MMLT see it: any bytes → an image or an error; an
//! image → the mask's input or an error; an input → a mask, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mixmc::exrio::ExrImage;
use mixmc::layout::{Names, Preset, Source};
use mixmc::mask::{MaskInput, MaskParams, build};

fuzz_target!(|data: &[u8]| {
    if let Ok(img) = ExrImage::from_bytes(data) {
        let _ = img.require("alpha");
        if let Ok(src) = Source::new(Preset::Mixmc, Names::default(), vec![("fuzz".into(), img)])
            && let Ok((input, _)) = MaskInput::from_source(&src)
        {
            build(&input, &MaskParams::default());
        }
    }
});
