//! Mitsuba XML scenes: any bytes → parse, interpret (includes, substitution, transforms,
//! shapes, BSDFs) and build (meshes, BVH, lights) must give a scene or an error, never a panic.
//! Relative files (includes, PLY, OBJ) resolve under a directory that does not exist.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mixmc::scene::{Scene, mitsuba};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let path = Path::new("/nonexistent/fuzz.xml");
        if let Ok(imported) = mitsuba::from_text(text, path) {
            let _ = Scene::from_imported(imported, path);
        }
    }
});
