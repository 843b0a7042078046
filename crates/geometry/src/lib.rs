//! lightlab-geometry
