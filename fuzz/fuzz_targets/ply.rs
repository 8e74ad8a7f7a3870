//! PLY meshes: any bytes → positions and faces or an error, never a panic, and no allocation
//! beyond what the file's size can hold.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(m) = mixmc::scene::mitsuba::ply::parse(data) {
        for i in 0..m.indices.len() {
            let _ = m.triangle(i);
        }
    }
});
