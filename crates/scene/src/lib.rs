//! lightlab-scene
