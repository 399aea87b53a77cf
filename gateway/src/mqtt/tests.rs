//! Tests of the client against a fake broker in virtual time.
