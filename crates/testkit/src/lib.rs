//! lightlab-testkit
