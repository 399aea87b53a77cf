//! The status mirror's second source: the controller's DataSheet port
//! (chapter 5, JSON packets at 20/10/5 Hz on 10004/10005/10006), read with
//! the codec's deframer and JSON reader. It spares the command port: with
//! `CFG_STATUS_SOURCE = 1` the engine stops its polling rounds (motion
//! completion still polls `ReadRobotState`, which is exact).
//!
//! The DataSheet connection goes to the robot's address (connect mode) or
//! to the address the controller connected from (listen mode), on
//! `CFG_DATASHEET_PORT`. When it fails it is retried every second; the
//! status age register shows how fresh the data is.

use core::convert::Infallible;
use core::net::{Ipv4Addr, SocketAddrV4};

use embassy_time::{with_timeout, Duration, Instant, Timer};
use hans_codec::datasheet::{DataSheet, Deframer};

use crate::config::{StatusSource, WordOrder};
use crate::gateway::Ctx;
use crate::net::Socket;
use crate::registers::{self as r, RegisterFile};

/// Largest DataSheet payload accepted (a controller's is ~3 KiB).
pub const PAYLOAD_MAX: usize = 6144;

fn bits(v: &[i32]) -> u16 {
    v.iter()
        .take(16)
        .enumerate()
        .filter(|(_, x)| **x != 0)
        .fold(0, |a, (i, _)| a | (1 << i))
}

/// Copies a DataSheet into the status registers.
pub fn apply(sheet: &DataSheet, regs: &mut RegisterFile, order: WordOrder) {
    let st = &sheet.state;
    if let Some(fsm) = st.robot_state {
        regs.set(
            r::STATUS_FSM,
            u16::try_from(i32::from(fsm)).unwrap_or(u16::MAX),
        );
    }
    let mut flags = regs.get(r::STATUS_FLAGS) | r::FLAG_VALID;
    let mut set = |on: Option<bool>, bit: u16| {
        if let Some(on) = on {
            flags = if on { flags | bit } else { flags & !bit };
        }
    };
    set(st.moving, r::FLAG_MOVING);
    set(st.enabled, r::FLAG_ENABLED);
    set(st.paused, r::FLAG_PAUSED);
    set(st.blending_done, r::FLAG_BLENDING_DONE);
    set(st.in_pos, r::FLAG_IN_POSITION);
    set(st.error_code.map(|c| c != 0), r::FLAG_ERROR);
    regs.set(r::STATUS_FLAGS, flags);
    if let Some(c) = st.error_code {
        regs.set_i32(r::STATUS_ERROR_CODE, c, order);
    }
    if let Some(a) = st.error_axis_id {
        regs.set(r::STATUS_ERROR_AXIS, u16::try_from(a).unwrap_or(u16::MAX));
    }
    let pv = &sheet.pos_and_vel;
    if let Some(p) = &pv.position {
        for (i, v) in p.joints.iter().enumerate() {
            regs.set_f32(r::STATUS_JOINTS + 2 * i as u16, v.to_f32(), order);
        }
    }
    if let Some(pose) = pv.pcs_tcp.or(pv.position.and_then(|p| p.pose)) {
        for (i, v) in pose.iter().enumerate() {
            regs.set_f32(r::STATUS_POSE + 2 * i as u16, v.to_f32(), order);
        }
    }
    if let Some(o) = pv.override_ratio {
        regs.set_f32(r::STATUS_OVERRIDE, o.to_f32(), order);
    }
    let mut valid = regs.get(r::STATUS_IO_VALID);
    let io = [
        (&sheet.box_io.box_di[..], r::STATUS_BOX_DI, 1 << 0),
        (&sheet.box_io.box_do[..], r::STATUS_BOX_DO, 1 << 1),
        (&sheet.box_io.box_ci[..], r::STATUS_BOX_CI, 1 << 2),
        (&sheet.box_io.box_co[..], r::STATUS_BOX_CO, 1 << 3),
        (&sheet.end_io.end_di[..], r::STATUS_END_DI, 1 << 4),
        (&sheet.end_io.end_do[..], r::STATUS_END_DO, 1 << 5),
    ];
    for (v, reg, bit) in io {
        if !v.is_empty() {
            regs.set(reg, bits(v));
            valid |= bit;
        }
    }
    regs.set(r::STATUS_IO_VALID, valid);
}

/// Where to read the DataSheet now, if configured.
fn target(ctx: &Ctx<'_>) -> Option<(SocketAddrV4, u32)> {
    ctx.with(|s| {
        if s.config.status_source != StatusSource::DataSheet {
            return None;
        }
        let ip = match s.config.link_mode {
            crate::config::LinkMode::Connect => s.config.robot_ip,
            crate::config::LinkMode::Listen => s.robot_peer.unwrap_or(Ipv4Addr::UNSPECIFIED),
        };
        (!ip.is_unspecified())
            .then(|| (SocketAddrV4::new(ip, s.config.datasheet_port), s.config_gen))
    })
}

/// Reads the DataSheet whenever it is the configured status source.
pub(crate) async fn run<S: Socket>(ctx: &Ctx<'_>, mut sock: S) -> Infallible {
    let mut deframer = Deframer::<PAYLOAD_MAX>::new();
    let mut buf = [0u8; 512];
    loop {
        let Some((addr, gen)) = target(ctx) else {
            Timer::after_millis(200).await;
            continue;
        };
        match with_timeout(Duration::from_secs(3), sock.connect(addr)).await {
            Ok(Ok(())) => info!("datasheet: connected to port {}", addr.port()),
            _ => {
                sock.close().await;
                Timer::after_secs(1).await;
                continue;
            }
        }
        deframer.reset();
        loop {
            if target(ctx).map(|(_, g)| g) != Some(gen) {
                break;
            }
            let n = match with_timeout(Duration::from_secs(2), sock.read(&mut buf)).await {
                Ok(Ok(n)) if n > 0 => n,
                _ => break,
            };
            // Each sheet is applied where it is parsed: a DataSheet is ~2 KiB,
            // one on the stack is enough.
            deframer.feed(buf.get(..n).unwrap_or(&[]), |item| {
                if let Ok(Ok(sheet)) = item.map(DataSheet::parse) {
                    ctx.with(|s| {
                        let order = s.config.word_order;
                        apply(&sheet, s.regs, order);
                        s.status_time = Some(Instant::now());
                    });
                }
            });
        }
        info!("datasheet: connection ended");
        sock.close().await;
        Timer::after_millis(200).await;
    }
}
