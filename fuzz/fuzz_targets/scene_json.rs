//! Scene files: any bytes → parse and build (meshes, BVH, lights) must give a scene or an
//! error, never a panic. OBJ paths resolve under a directory that does not exist.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = mixmc::scene::Scene::from_text(text, Path::new("/nonexistent/fuzz.json"));
    }
});
