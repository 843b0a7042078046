//! Crafted input files for bad-input tests.

/// The header of an uncompressed scanline OpenEXR file (one f32 channel `Y`) declaring a
/// `width` × `height` data window, with no offset table or pixels after it: a few hundred bytes
/// that claim as many pixels as asked (the OpenEXR file layout, openexr.com "OpenEXR File Layout").
pub fn exr_header_only(width: i32, height: i32) -> Vec<u8> {
    fn attribute(out: &mut Vec<u8>, name: &str, kind: &str, value: &[u8]) {
        for s in [name, kind] {
            out.extend(s.as_bytes());
            out.push(0);
        }
        out.extend((value.len() as i32).to_le_bytes());
        out.extend(value);
    }
    let mut out = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    // Channel `Y`: pixel type 2 (f32), pLinear and reserved 0, sampling 1 × 1; then the list's end.
    let mut channels = b"Y\0".to_vec();
    for v in [2i32, 0, 1, 1] {
        channels.extend(v.to_le_bytes());
    }
    channels.push(0);
    attribute(&mut out, "channels", "chlist", &channels);
    attribute(&mut out, "compression", "compression", &[0]);
    let window: Vec<u8> = [0, 0, width - 1, height - 1]
        .iter()
        .flat_map(|v: &i32| v.to_le_bytes())
        .collect();
    attribute(&mut out, "dataWindow", "box2i", &window);
    attribute(&mut out, "displayWindow", "box2i", &window);
    attribute(&mut out, "lineOrder", "lineOrder", &[0]);
    attribute(&mut out, "pixelAspectRatio", "float", &1f32.to_le_bytes());
    attribute(&mut out, "screenWindowCenter", "v2f", &[0; 8]);
    attribute(&mut out, "screenWindowWidth", "float", &1f32.to_le_bytes());
    out.push(0);
    out
}
