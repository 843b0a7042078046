//! lightlab-materials
