//! `hans-fw` as a program: a key made, a firmware signed, the image checked
//! as the device checks it, and every kind of bad image refused with its
//! reason (exit status 1).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_hans-fw");

fn run(args: &[&str]) -> Output {
    Command::new(BIN).args(args).output().expect("run hans-fw")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

struct Dir(PathBuf);

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[test]
fn keygen_sign_verify_and_inspect() {
    let dir = Dir(std::env::temp_dir().join(format!("hans-fw-{}", std::process::id())));
    std::fs::create_dir_all(&dir.0).unwrap();
    let d = &dir.0;
    let out = run(&["keygen", "--out", s(d), "--name", "plant"]);
    assert!(out.status.success(), "{out:?}");
    use std::os::unix::fs::PermissionsExt;
    let mode = std::fs::metadata(d.join("plant.key"))
        .unwrap()
        .permissions()
        .mode();
    assert_eq!(mode & 0o777, 0o600, "the secret key is its owner's only");
    // A second keygen never overwrites a key.
    assert!(!run(&["keygen", "--out", s(d), "--name", "plant"])
        .status
        .success());
    assert!(run(&["keygen", "--out", s(d), "--name", "other"])
        .status
        .success());

    let fw = d.join("fw.bin");
    let body: Vec<u8> = (0..70_000u32).map(|i| (i % 253) as u8).collect();
    std::fs::write(&fw, &body).unwrap();
    let img = d.join("fw.img");
    let key = d.join("plant.key");
    let public = d.join("plant.pub");
    let out = run(&[
        "sign",
        "--key",
        s(&key),
        "--board",
        "mps2-an386",
        "--version",
        "1.4.0",
        s(&fw),
        "-o",
        s(&img),
    ]);
    assert!(out.status.success(), "{out:?}");
    let verify = |image: &Path, extra: &[&str]| {
        let mut a = vec!["verify", "--pub", s(&public), "--board", "mps2-an386"];
        a.extend_from_slice(extra);
        a.push(s(image));
        run(&a)
    };
    let out = verify(&img, &["--running", "1.3.9"]);
    assert!(out.status.success(), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("ok: mps2-an386 1.4.0"));

    let refused = |out: Output, why: &str| {
        assert_eq!(out.status.code(), Some(1), "{out:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(why), "{why:?} in {err}");
    };
    // Another key's public half.
    refused(
        run(&[
            "verify",
            "--pub",
            s(&d.join("other.pub")),
            "--board",
            "mps2-an386",
            s(&img),
        ]),
        "not signed by the trusted key",
    );
    // Another board.
    refused(
        run(&[
            "verify",
            "--pub",
            s(&public),
            "--board",
            "nucleo-f767zi",
            s(&img),
        ]),
        "image for another board",
    );
    // Older than the running one, then allowed.
    refused(
        verify(&img, &["--running", "2.0.0"]),
        "downgrade not allowed",
    );
    assert!(verify(&img, &["--running", "2.0.0", "--allow-downgrade"])
        .status
        .success());
    // Truncated and corrupted.
    let bytes = std::fs::read(&img).unwrap();
    let cut = d.join("cut.img");
    std::fs::write(&cut, &bytes[..bytes.len() - 1000]).unwrap();
    refused(verify(&cut, &[]), "truncated");
    let bad = d.join("bad.img");
    let mut b = bytes.clone();
    b[5000] ^= 0x10;
    std::fs::write(&bad, &b).unwrap();
    refused(verify(&bad, &[]), "corrupted");
    refused(verify(&fw, &[]), "not a firmware image");

    // Inspect needs no key.
    let out = run(&["inspect", s(&cut)]);
    assert!(out.status.success(), "{out:?}");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("board    mps2-an386") && text.contains("version  1.4.0"),
        "{text}"
    );
    assert!(
        text.contains("70000 bytes (the file has 69000: truncated or extended)"),
        "{text}"
    );
    // A bad command line is status 2.
    assert_eq!(run(&["sign", "--version", "1.x"]).status.code(), Some(2));
}
