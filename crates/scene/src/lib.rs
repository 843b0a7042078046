//! Scenes: the RON description (`desc`), the Mitsuba 3 XML importer into it (`mitsuba`), the loader that turns it into an immutable, `Sync` [`Scene`]
//! (geometry in a BVH, materials as BSDFs, lights with power-proportional selection), and the camera.
//!
//! ```no_run
//! let scene = lightlab_scene::load_scene("scenes/cornell-box.ron".as_ref()).unwrap();
//! assert_eq!(scene.camera.width, 256);
//! ```

mod camera;
pub mod desc;
mod envmap;
mod error;
mod image;
pub use image::check_exr_size;
mod light;
mod load;
pub mod mitsuba;
pub mod overrides;
mod scene;
pub mod text;
mod textures;

pub use camera::{Camera, CameraSample};
pub use envmap::EnvMap;
pub use error::SceneError;
pub use light::{Light, LightEmission, LightSample, SpotProfile, spot_falloff};
pub use load::{build_scene, load_scene, parse_scene};
pub use scene::Scene;

/// A RON error's message, with what is allowed where RON's own words do not say it.
pub fn ron_message(code: &ron::Error) -> String {
    match code {
        ron::Error::IntegerOutOfBounds => "Integer is out of bounds: this field holds a whole \
            number ≥ 0, at most 4294967295 for counts and sizes (2⁶⁴ − 1 for seeds)"
            .into(),
        other => other.to_string(),
    }
}

/// The largest image side, in pixels, wherever a resolution is given (scene files, Mitsuba films,
/// `--resolution`, experiments): a film keeps ≈ 80 bytes per pixel, so 16384² is already 21 GB, and
/// larger sides overflowed the allocation's size into an abort.
pub const MAX_RESOLUTION: u32 = 16384;
