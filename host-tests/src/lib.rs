//! Host-side support for the codec's tests and benchmarks.
//!
//! * [`corpus`]: the test-vector corpus under `host-tests/vectors/` (reader,
//!   evaluation against the codec, and a rendition in the same format).
//! * [`dump`]: a [`hans_codec::Visitor`] that writes a message's typed values
//!   as one line of text (`rbt_id=0 pose=[420 0 445 180 0 180]`).

pub mod corpus;
pub mod dump;
