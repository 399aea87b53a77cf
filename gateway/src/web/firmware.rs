//! `POST /api/firmware`: an administrator uploads a signed firmware image
//! (`Content-Type: application/octet-stream`, the image as `hans-fw sign`
//! wrote it); `?downgrade=allow` lets an older version in.
//!
//! The image is checked before a byte of it is installed: its header
//! first (signature by the trusted key, board, version, size, and the
//! length the request declares), before anything is written; then the
//! body, hashed as it streams into the download slot in
//! [`PIECE`](crate::update::PIECE)-byte pieces through the storage task
//! (the only owner of the flash); the slot is marked for the swap only if
//! the hash is the signed one. A refused image leaves the running firmware
//! and the versions the status shows (running, previous) as they were,
//! with its reason in the answer, the status (`firmware.upload`), the log
//! and the audit log; an update that waited for the restart is unmarked
//! once a refused image's bytes were written over it.
//!
//! Bounds: one upload at a time (409 for a second); the next bytes must
//! come within [`UPLOAD_STALL`] and the whole image within
//! [`UPLOAD_DEADLINE`], else the upload is dropped and the connection
//! closed: an administrator's slow client holds one web slot no longer.
//! While it runs the engine and the Modbus sessions go on: the upload
//! waits for the network and the flash, never they for it.
//!
//! The restart that swaps the image in is a separate step
//! (`POST /api/restart`, which asks for confirmation while a motion runs).

use embassy_time::{Duration, Instant};
use picoserve::io::Read;
use picoserve::request::Request;
use picoserve::response::StatusCode;

use super::json::Json;
use super::{error, error_json, App, Reply};
use crate::access::session::Who;
use crate::audit::{Event, Who as AuditWho};
use crate::clock::{with_deadline, Clock};
use crate::update::{Op, SlotError, Upload, Version, PIECE};
use hans_fw_image::layout::HEADER_PAGE;
use hans_fw_image::{Expect, ImageError, Verifier, HEADER_LEN};

/// The longest wait for the next bytes of an upload.
pub(crate) const UPLOAD_STALL: Duration = Duration::from_secs(5);
/// An upload must be whole this long after it began (a 512 KiB slot at
/// 16 KiB/s, a slow link's rate).
pub(crate) const UPLOAD_DEADLINE: Duration = Duration::from_secs(32);

/// Why an upload ended without an installed image.
enum Failed {
    /// The image was refused (its reason).
    Image(ImageError),
    /// The slots refused or failed.
    Slot(SlotError),
    /// The client was too slow, or went away.
    Client(&'static str),
}

impl Failed {
    fn reason(&self) -> &'static str {
        match self {
            Failed::Image(e) => e.as_str(),
            Failed::Slot(e) => e.as_str(),
            Failed::Client(why) => why,
        }
    }
}

fn version_text(v: Version) -> impl core::fmt::Display {
    struct V(Version);
    impl core::fmt::Display for V {
        fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
            write!(f, "{}.{}.{}", self.0.major, self.0.minor, self.0.patch)
        }
    }
    V(v)
}

impl<C: Clock> App<'_, C> {
    /// `POST /api/firmware` (an administrator's session, checked by the
    /// caller).
    pub(super) async fn post_firmware<R: Read>(
        &self,
        who: Who,
        downgrade: bool,
        request: &mut Request<'_, R>,
    ) -> Reply {
        let updates = &self.hub.updates;
        let status = self.hub.with(|m| m.firmware);
        let trust = updates.trust();
        let (Some((key, board, max_body)), true) = (trust, status.supported) else {
            return error(StatusCode::NOT_IMPLEMENTED, SlotError::Unsupported.as_str());
        };
        let Some(_mailbox) = updates.try_take() else {
            return error(StatusCode::CONFLICT, "another upload is in progress");
        };
        let expect = Expect {
            key: &key,
            board,
            running: status.running.unwrap_or(Version {
                major: 0,
                minor: 0,
                patch: 0,
            }),
            allow_downgrade: downgrade,
            max_body,
        };
        let name = self.name_of(who);
        let actor = name.as_ref().map_or(&[][..], |n| n.as_bytes());
        let from = self.peer.map(|p| *p.ip());
        let result = self.receive(&expect, request).await;
        match result {
            Ok(v) => {
                self.hub.with(|m| {
                    let s = &mut m.firmware;
                    s.upload = Upload::Installed { version: v };
                    s.boot = Some(crate::update::BootState::Pending);
                });
                info!(
                    "update: firmware {}.{}.{} written and marked: the next restart installs it",
                    v.major, v.minor, v.patch
                );
                let mut detail = heapless::String::<32>::new();
                let _ =
                    core::fmt::write(&mut detail, format_args!("installed {}", version_text(v)));
                self.hub.audit(Event::Firmware {
                    who: AuditWho::web(actor, from),
                    detail: detail.as_str(),
                });
                let j = Json::value(|v2| {
                    v2.object(|j| {
                        j.key("ok").bool(true);
                        j.key("version").text(|t| {
                            t.uint(v.major.into()).str(b".").uint(v.minor.into());
                            t.str(b".").uint(v.patch.into());
                        });
                        j.key("restart_needed").bool(true);
                    })
                })
                .unwrap_or_else(|_| error_json("answer"));
                Reply::Json(StatusCode::OK, j)
            }
            Err(failed) => {
                let reason = failed.reason();
                self.hub
                    .with(|m| m.firmware.upload = Upload::Refused { reason });
                // Writing into the download slot unmarks an update that
                // was waiting for the restart (its image is overwritten):
                // the boot state says what the flash says now. The
                // versions stay: nothing else changed (the previous one is
                // the version the running firmware replaced).
                let _ = updates.ask(Op::BootState).await;
                warn!("update: upload refused: {}", reason);
                let mut detail = heapless::String::<80>::new();
                let _ = core::fmt::write(&mut detail, format_args!("refused: {reason}"));
                self.hub.audit(Event::Firmware {
                    who: AuditWho::web(actor, from),
                    detail: detail.as_str(),
                });
                let status = match failed {
                    Failed::Image(ImageError::TooLarge) => StatusCode::PAYLOAD_TOO_LARGE,
                    Failed::Image(_) => StatusCode::UNPROCESSABLE_ENTITY,
                    Failed::Slot(SlotError::OnTrial) => StatusCode::CONFLICT,
                    Failed::Slot(_) => StatusCode::INTERNAL_SERVER_ERROR,
                    Failed::Client(_) => StatusCode::REQUEST_TIMEOUT,
                };
                // What is left of the body is never read: the connection
                // closes after the answer.
                Reply::Close(status, error_json(reason))
            }
        }
    }

    /// Reads, checks and writes the image; its version once it is marked.
    #[allow(clippy::await_holding_refcell_ref)] // the piece's borrow: see below
    async fn receive<R: Read>(
        &self,
        expect: &Expect<'_>,
        request: &mut Request<'_, R>,
    ) -> Result<Version, Failed> {
        let updates = &self.hub.updates;
        let body = request.body_connection.body();
        let total = body.content_length();
        if total < HEADER_LEN {
            return Err(Failed::Image(ImageError::TooShort));
        }
        if total - HEADER_LEN > expect.max_body as usize {
            return Err(Failed::Image(ImageError::TooLarge));
        }
        // The request's own timeout (picoserve's, the whole request within
        // two seconds) is replaced by the stall and deadline below.
        let mut reader = body
            .reader()
            .with_different_timeout_signal(core::future::pending::<()>());
        let deadline = self.clock.now() + UPLOAD_DEADLINE;
        // The header is read into the piece buffer, where it is handed to
        // the storage task from (no copy of it in every web slot's future).
        let (mut verifier, header) = {
            let Ok(mut piece) = updates.piece.try_borrow_mut() else {
                return Err(Failed::Slot(SlotError::Flash));
            };
            let head = piece.get_mut(..HEADER_LEN).unwrap_or(&mut []);
            self.fill(&mut reader, head, deadline).await?;
            let verifier = Verifier::new(head, expect).map_err(Failed::Image)?;
            let header = *verifier.header();
            (verifier, header)
        };
        if total - HEADER_LEN != header.body_len as usize {
            return Err(Failed::Image(ImageError::WrongLength));
        }
        self.hub.with(|m| {
            let s = &mut m.firmware;
            s.upload = Upload::Receiving {
                version: header.version,
                received: HEADER_LEN as u32,
                total: total as u32,
            }
        });
        let v = header.version;
        info!(
            "update: receiving firmware {}.{}.{} ({} bytes)",
            v.major, v.minor, v.patch, total
        );
        // The header at the slot's start, the body one header page on.
        let write = Op::Write {
            offset: 0,
            len: HEADER_LEN,
        };
        updates.ask(write).await.map_err(Failed::Slot)?;
        let mut offset = HEADER_PAGE;
        let mut left = header.body_len as usize;
        while left > 0 {
            let n = left.min(PIECE);
            // The piece is filled from the socket while held: the storage
            // task reads it only when asked (below), after this borrow
            // ends; a contended borrow would fail the upload, not panic.
            {
                let Ok(mut piece) = updates.piece.try_borrow_mut() else {
                    return Err(Failed::Slot(SlotError::Flash));
                };
                let part = piece.get_mut(..n).unwrap_or(&mut []);
                self.fill(&mut reader, part, deadline).await?;
                verifier.update(part).map_err(Failed::Image)?;
            }
            let write = Op::Write { offset, len: n };
            updates.ask(write).await.map_err(Failed::Slot)?;
            offset += n as u32;
            left -= n;
            let received = (total - left) as u32;
            self.hub.with(|m| {
                let s = &mut m.firmware;
                if let Upload::Receiving { received: r, .. } = &mut s.upload {
                    *r = received;
                }
            });
        }
        let header = verifier.finish().map_err(Failed::Image)?;
        updates.ask(Op::MarkUpdated).await.map_err(Failed::Slot)?;
        Ok(header.version)
    }

    /// Fills `buf` from the body: each read within [`UPLOAD_STALL`], all by
    /// `deadline`.
    async fn fill<R: Read>(
        &self,
        reader: &mut R,
        buf: &mut [u8],
        deadline: Instant,
    ) -> Result<(), Failed> {
        let mut at = 0;
        while let Some(rest) = buf.get_mut(at..).filter(|r| !r.is_empty()) {
            let by = (self.clock.now() + UPLOAD_STALL).min(deadline);
            match with_deadline(self.clock, by, reader.read(rest)).await {
                Ok(Ok(0)) | Ok(Err(_)) => {
                    return Err(Failed::Client("the upload ended early (connection closed)"))
                }
                Ok(Ok(n)) => at += n,
                Err(_) => return Err(Failed::Client("the upload was too slow (timed out)")),
            }
        }
        Ok(())
    }
}
