//! Solves per second of each estimator on one joint seen by 3, 6 and 16 sensors.
fn main() {}
