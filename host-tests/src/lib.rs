//! Host-side support for tests, the simulator and tools.
