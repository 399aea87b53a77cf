//! `hansctl`: decode and send Hans protocol messages.
fn main() {}
