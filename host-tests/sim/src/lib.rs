//! Simulator of a Hans / Huayan robot controller.
