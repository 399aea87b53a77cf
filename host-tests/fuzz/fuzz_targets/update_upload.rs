//! A firmware upload over HTTP (`POST /api/firmware`), streamed in reads
//! of any size through the gateway's web server into a board's flash (the
//! testkit's, with the QEMU board's layout), in virtual time: a signed image
//! changed by the input (bytes flipped, cut short, or the input itself as
//! the image). Never a panic; an answer always comes and the connection
//! closes; the upload is installed (200, the boot state "pending", the
//! download slot holding the image's header) exactly when the whole image
//! passes the one-shot check (`hans_fw_image::check`), so the streamed
//! path and the one-shot check agree; a refused upload never marks an
//! update.
//!
//! One world per process, its administrator's session opened once.
//! Input: byte 0 picks the read size (1-2048 bytes), byte 1 the mode
//! (0: the input is the image; 1: the signed image with the input's
//! (offset, xor) pairs applied; 2: the signed image cut at the input's
//! offset); the rest drives the mode.
#![no_main]

use core::cell::RefCell;
use core::net::Ipv4Addr;

use embassy_time::Duration;
use hans_gateway::testkit::flash::{sign, test_key, version, SimFlash, TEST_KEY_SEED};
use hans_gateway::testkit::world::{MemStorage, World, WorldConfig, SETUP_CODE};
use hans_fw_image::layout::MPS2_AN386;
use hans_fw_image::{check, Expect};
use libfuzzer_sys::fuzz_target;

const PC: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 60);

struct Rig {
    w: World,
    flash: SimFlash,
    token: String,
    image: Vec<u8>,
}

thread_local! {
    static RIG: RefCell<Option<Rig>> = const { RefCell::new(None) };
}

fn request(path: &str, headers: &[(&str, &str)], body: &[u8]) -> Vec<u8> {
    let mut r = format!("POST {path} HTTP/1.1\r\nHost: 192.168.1.50\r\nConnection: close\r\nOrigin: http://192.168.1.50\r\n");
    for (n, v) in headers {
        r.push_str(&format!("{n}: {v}\r\n"));
    }
    r.push_str(&format!("Content-Length: {}\r\n\r\n", body.len()));
    let mut r = r.into_bytes();
    r.extend_from_slice(body);
    r
}

fn status(answer: &[u8]) -> Option<u16> {
    let line = answer.split(|b| *b == b'\r').next()?;
    std::str::from_utf8(line)
        .ok()?
        .split(' ')
        .nth(1)?
        .parse()
        .ok()
}

fn make() -> Rig {
    let flash = SimFlash::new();
    let body: Vec<u8> = (0..6000u32).map(|i| (i * 7 % 253) as u8).collect();
    flash.install(&sign(
        &TEST_KEY_SEED,
        MPS2_AN386.board,
        version(1, 0, 0),
        &body,
    ));
    let mut storage = MemStorage::default();
    storage.flash = Some(flash.clone());
    let mut w = World::new(WorldConfig {
        web: true,
        storage,
        ..WorldConfig::default()
    });
    w.run_for(Duration::from_millis(50));
    let setup = format!(r#"{{"code":"{SETUP_CODE}","name":"admin","password":"correct horse"}}"#);
    let got = w.http(
        PC,
        &request(
            "/api/setup",
            &[("Content-Type", "application/json")],
            setup.as_bytes(),
        ),
        Duration::from_secs(10),
    );
    let text = String::from_utf8_lossy(&got);
    let token = text
        .split("hgw_session=")
        .nth(1)
        .and_then(|t| t.split(';').next())
        .expect("a session")
        .to_string();
    let image = sign(
        &TEST_KEY_SEED,
        MPS2_AN386.board,
        version(1, 1, 0),
        &body[..5000],
    );
    Rig {
        w,
        flash,
        token,
        image,
    }
}

fuzz_target!(|data: &[u8]| {
    let [size, mode, rest @ ..] = data else {
        return;
    };
    RIG.with(|cell| {
        let mut guard = cell.borrow_mut();
        let rig = guard.get_or_insert_with(make);
        let image = match mode % 3 {
            0 => rest.to_vec(),
            1 => {
                let mut img = rig.image.clone();
                for p in rest.chunks_exact(3) {
                    let at = usize::from(u16::from_le_bytes([p[0], p[1]])) % img.len();
                    img[at] ^= p[2];
                }
                img
            }
            _ => {
                let cut = rest
                    .iter()
                    .fold(0usize, |a, b| a.wrapping_mul(256) ^ usize::from(*b));
                rig.image[..cut % (rig.image.len() + 1)].to_vec()
            }
        };
        let key = test_key();
        let before = rig.flash.marked();
        let expect = Expect {
            key: &key,
            board: MPS2_AN386.board,
            running: version(1, 0, 0),
            allow_downgrade: false,
            max_body: MPS2_AN386.max_body(),
        };
        let should = check(&image, &expect);
        let cookie = format!("hgw_session={}", rig.token);
        let raw = request(
            "/api/firmware",
            &[
                ("Cookie", cookie.as_str()),
                ("Content-Type", "application/octet-stream"),
            ],
            &image,
        );
        let Some(mut conn) = rig.w.web_connect(PC) else {
            panic!("the web port is not served");
        };
        let step = usize::from(*size) * 8 + 1;
        let mut got = Vec::new();
        for chunk in raw.chunks(step) {
            if !conn.is_open() {
                break;
            }
            conn.write(chunk);
            rig.w.run_for(Duration::from_millis(1));
            got.extend(conn.read());
        }
        rig.w
            .run_until_cond(Duration::from_secs(12), |_| !conn.is_open());
        got.extend(conn.read());
        assert!(
            !conn.is_open(),
            "connection still open after the upload's limits"
        );
        let code = status(&got).expect("an HTTP answer");
        let after = rig.flash.marked();
        match should {
            Ok(h) => {
                assert_eq!(
                    code,
                    200,
                    "a good image refused: {}",
                    String::from_utf8_lossy(&got)
                );
                assert!(after, "installed but not marked");
                assert_eq!(
                    rig.flash.header(true),
                    Some(h),
                    "the download slot's header"
                );
            }
            Err(e) => {
                assert_ne!(code, 200, "a bad image ({e:?}) installed");
                assert!(!after || before, "a refused upload marked an update");
            }
        }
    })
});
