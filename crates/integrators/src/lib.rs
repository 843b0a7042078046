//! lightlab-integrators
