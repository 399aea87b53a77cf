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

/// `install` writes the flash a bootloader finds: erased, the image's
/// header at the active slot's start, its body a header page further; the
/// download slot likewise with `--dfu`; another board's or a truncated
/// image is refused.
#[test]
fn install_writes_a_flash_file() {
    let dir = Dir(std::env::temp_dir().join(format!("hans-fw-install-{}", std::process::id())));
    std::fs::create_dir_all(&dir.0).unwrap();
    let d = &dir.0;
    assert!(run(&["keygen", "--out", s(d), "--name", "k"])
        .status
        .success());
    let sign = |body: &[u8], board: &str, version: &str, name: &str| {
        let fw = d.join(format!("{name}.bin"));
        std::fs::write(&fw, body).unwrap();
        let img = d.join(format!("{name}.img"));
        let k = d.join("k.key");
        let out = run(&[
            "sign",
            "--key",
            s(&k),
            "--board",
            board,
            "--version",
            version,
            s(&fw),
            "-o",
            s(&img),
        ]);
        assert!(out.status.success(), "{out:?}");
        img
    };
    let a_body: Vec<u8> = (0..9_000u32).map(|i| (i % 251) as u8).collect();
    let b_body: Vec<u8> = (0..5_000u32).map(|i| (i % 13) as u8).collect();
    let a = sign(&a_body, "mps2-an386", "0.1.0", "a");
    let b = sign(&b_body, "mps2-an386", "0.2.0", "b");
    let flash = d.join("flash.bin");
    let out = run(&[
        "install",
        "--layout",
        "mps2-an386",
        "--out",
        s(&flash),
        s(&a),
        "--dfu",
        s(&b),
    ]);
    assert!(out.status.success(), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("0.1.0 in the active slot"));

    // MPS2_AN386: state 0..0x1000, active 0x1000.., download 0x8_1000..,
    // the gateway's store 0x10_2000.. (erased), 0x11_2000 bytes; the body a
    // 1 KiB header page after the header.
    let f = std::fs::read(&flash).unwrap();
    assert_eq!(f.len(), 0x11_2000);
    assert!(f[0x10_2000..].iter().all(|b| *b == 0xFF), "store erased");
    let (a_img, b_img) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    let slot = |at: usize, img: &[u8], body: &[u8]| {
        assert_eq!(&f[at..at + 136], &img[..136], "header at {at:#x}");
        assert!(
            f[at + 136..at + 1024].iter().all(|b| *b == 0xFF),
            "padding erased"
        );
        assert_eq!(
            &f[at + 1024..at + 1024 + body.len()],
            body,
            "body at {at:#x}"
        );
        at + 1024 + body.len()
    };
    let a_end = slot(0x1000, &a_img, &a_body);
    let b_end = slot(0x8_1000, &b_img, &b_body);
    assert!(f[..0x1000].iter().all(|b| *b == 0xFF), "no swap marked");
    assert!(f[a_end..0x8_1000].iter().all(|b| *b == 0xFF));
    assert!(f[b_end..].iter().all(|b| *b == 0xFF));

    // The NUCLEO's first flashing: the active slot's bytes alone, for a
    // probe at 0x0802_0000 (header, erased padding, body; nothing else).
    let n = sign(&a_body, "nucleo-f767zi", "1.0.0", "nucleo");
    let slot_file = d.join("active.bin");
    let out = run(&[
        "install",
        "--layout",
        "nucleo-f767zi",
        "--slot-only",
        "--out",
        s(&slot_file),
        s(&n),
    ]);
    assert!(out.status.success(), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("at offset 0x20000"));
    let sf = std::fs::read(&slot_file).unwrap();
    let n_img = std::fs::read(&n).unwrap();
    assert_eq!(sf.len(), 1024 + a_body.len());
    assert_eq!(&sf[..136], &n_img[..136]);
    assert!(sf[136..1024].iter().all(|b| *b == 0xFF));
    assert_eq!(&sf[1024..], &a_body[..]);

    let refused = |args: &[&str], why: &str| {
        let out = run(args);
        assert_eq!(out.status.code(), Some(1), "{out:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(why), "{why:?} in {err}");
    };
    let other = sign(&a_body, "nucleo-f767zi", "0.1.0", "n");
    refused(
        &[
            "install",
            "--layout",
            "mps2-an386",
            "--out",
            s(&flash),
            s(&other),
        ],
        "an image for nucleo-f767zi, not mps2-an386",
    );
    let cut = d.join("cut.img");
    std::fs::write(&cut, &a_img[..a_img.len() - 10]).unwrap();
    refused(
        &[
            "install",
            "--layout",
            "mps2-an386",
            "--out",
            s(&flash),
            s(&cut),
        ],
        "the header says 9000 bytes of firmware, the file has 8990",
    );
    refused(
        &[
            "install",
            "--layout",
            "mps2-an999",
            "--out",
            s(&flash),
            s(&a),
        ],
        "no layout for board",
    );
}
