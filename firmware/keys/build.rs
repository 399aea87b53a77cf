//! Rebuilds when the trusted key changes (see src/lib.rs).
fn main() {
    println!("cargo:rerun-if-env-changed=HANS_FW_PUBKEY");
    println!("cargo:rerun-if-changed=dev.pub");
    println!("cargo:rerun-if-changed=build.rs");
}
