//! OBJ meshes: any bytes → a mesh or an error; a mesh that loads must also transform and yield
//! its triangles without a panic (indices in range).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data)
        && let Ok(mesh) = mixmc::scene::obj::parse(text)
    {
        for i in 0..mesh.indices.len() {
            let _ = mesh.triangle(i);
        }
    }
});
