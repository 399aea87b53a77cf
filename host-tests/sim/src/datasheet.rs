//! The JSON DataSheet ports (chapter 5): every connected client receives a
//! packet (12-byte `LTBR` header + JSON, written by the codec's
//! `hans_codec::datasheet`) at the port's rate.
//!
//! Rates are in real time (20, 10 and 5 Hz for the three default ports;
//! further ports 5 Hz), whatever the clock mode: the content is the robot
//! at the simulated time of sending. At most [`MAX_CLIENTS`] clients per
//! port; further connections are closed at once. A client that does not
//! read loses the connection when the socket send buffer stays full for a
//! whole period (packets are never queued in the simulator).

use std::sync::Arc;
use std::time::Duration;

use hans_codec::datasheet::{
    BoxAnalogIo, BoxIo, DataSheet, EndIo, FtData, HardLoad, PosAndVel, Position, StateAndError,
};
use hans_codec::Decimal;
use tokio::io::AsyncWriteExt;
use tokio::net::{TcpListener, TcpStream};

use crate::robot::Snapshot;
use crate::server::{serve_clients, Shared};

/// Most clients per DataSheet port.
pub const MAX_CLIENTS: usize = 16;

fn dec(v: f64) -> Decimal {
    Decimal::from_f64(v, 3).unwrap_or(Decimal::ZERO)
}

fn decs<const N: usize>(v: [f64; N]) -> [Decimal; N] {
    v.map(dec)
}

fn bits<const N: usize>(v: &[bool]) -> heapless::Vec<i32, N> {
    v.iter().map(|&b| i32::from(b)).take(N).collect()
}

/// The DataSheet of a snapshot.
pub fn sheet_of(s: &Snapshot) -> DataSheet {
    let f = &s.flags;
    let enabled = f.enabled;
    DataSheet {
        pos_and_vel: PosAndVel {
            position: Some(Position {
                joints: decs(s.act_joints),
                pose: Some(decs(s.act_pose)),
            }),
            pcs_tcp: Some(decs(s.act_pose)),
            pcs_base: Some(decs(s.act_pose_base)),
            pcs_tool: None,
            joint_current: Some(decs(s.act_joint_cur)),
            joint_velocity: Some(decs(s.act_joint_vel)),
            joint_acceleration: Some(decs(s.act_joint_acc)),
            override_ratio: Some(dec(s.override_ratio)),
        },
        end_io: EndIo {
            end_di: bits(&s.io.end_di),
            end_do: bits(&s.io.end_do),
            end_button: bits(&s.io.end_button),
            enable_end_btn: Some(0),
            end_ai: s.io.end_ai.iter().map(|&v| dec(v)).collect(),
        },
        box_io: BoxIo {
            box_ci: bits(&s.io.ci),
            box_co: bits(&s.io.co),
            box_di: bits(&s.io.di),
            box_do: bits(&s.io.do_),
            conveyor: Some(Decimal::from_milli(0)),
            encode: Some(0),
        },
        box_analog_io: BoxAnalogIo {
            out_mode: [Some(s.io.ao_mode[0]), Some(s.io.ao_mode[1])],
            out: [Some(dec(s.io.ao[0])), Some(dec(s.io.ao[1]))],
            input: [Some(dec(s.io.ai[0])), Some(dec(s.io.ai[1]))],
        },
        state: StateAndError {
            robot_state: Some(s.fsm),
            enabled: Some(enabled),
            paused: Some(f.paused),
            moving: Some(f.moving),
            blending_done: Some(f.blending_done),
            in_pos: Some(f.in_position),
            error_axis_id: Some(f.error_axis),
            error_code: Some(f.error_code),
            brake_state: Some([i32::from(f.brake_released); 6]),
            axis_status: Some([if enabled { 3 } else { 0 }; 6]),
            axis_error_code: Some({
                let mut a = [0; 6];
                if f.error {
                    if let Some(x) = usize::try_from(f.error_axis)
                        .ok()
                        .and_then(|i| a.get_mut(i))
                    {
                        *x = f.error_code;
                    }
                }
                a
            }),
            reset_safe_space: heapless::Vec::from_slice(&[1]).unwrap_or_default(),
            axis_group_status: heapless::Vec::from_slice(&[i32::from(enabled)]).unwrap_or_default(),
            axis_group_error_code: heapless::Vec::from_slice(&[f.error_code]).unwrap_or_default(),
        },
        hard_load: HardLoad {
            ethercat_total_frame: Some(u64::try_from(s.time.as_millis()).unwrap_or(u64::MAX)),
            ethercat_frames_per_second: Some(if f.powered { 1000 } else { 0 }),
            ethercat_total_lost_frame: Some(0),
            ethercat_tx_error_frame: Some(0),
            ethercat_rx_error_frame: Some(0),
            box48_in_voltage: Some(dec(if f.box_connected { 48.0 } else { 0.0 })),
            box48_in_current: Some(dec(if f.powered { 1.0 } else { 0.0 })),
            box48_out_voltage: Some(dec(if f.powered { 48.0 } else { 0.0 })),
            box48_out_current: Some(dec(if enabled { 1.2 } else { 0.0 })),
            slave_temperature: [30.0, 30.0, 30.0].iter().map(|&v| dec(v)).collect(),
            slave_voltage: [if f.powered { 48.0 } else { 0.0 }; 3]
                .iter()
                .map(|&v| dec(v))
                .collect(),
        },
        ft: FtData {
            control_state: Some(s.ft_state),
            data: Some(decs(s.ft_data)),
            src_data: Some(decs(s.ft_data)),
        },
        script: hans_codec::datasheet::Script {
            error_code: Some(0),
        },
    }
}

/// One packet for the robot as it is now.
fn packet(shared: &Shared) -> Vec<u8> {
    let now = shared.now();
    let snap = {
        let mut r = shared.robot();
        r.update(now);
        r.snapshot(now)
    };
    let mut out = vec![0u8; 12 + DataSheet::MAX_JSON_LEN];
    match sheet_of(&snap).write_packet(&mut out) {
        Ok(n) => {
            out.truncate(n);
            out
        }
        Err(_) => Vec::new(),
    }
}

/// Accepts DataSheet clients on one port until shutdown.
pub(crate) async fn accept_loop(shared: Arc<Shared>, listener: TcpListener, period: Duration) {
    let pushing = shared.clone();
    serve_clients(
        &shared,
        listener,
        |n| n >= MAX_CLIENTS,
        move |stream| push(pushing.clone(), stream, period),
    )
    .await;
}

async fn push(shared: Arc<Shared>, mut stream: TcpStream, period: Duration) {
    let _ = stream.set_nodelay(true);
    let mut tick = tokio::time::interval(period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut shutdown = shared.shutdown.subscribe();
    loop {
        tokio::select! {
            _ = shutdown.changed() => return,
            _ = tick.tick() => {}
        }
        let bytes = packet(&shared);
        match tokio::time::timeout(
            period.max(Duration::from_millis(50)),
            stream.write_all(&bytes),
        )
        .await
        {
            Ok(Ok(())) => {}
            _ => return,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::{Initial, Robot, Timing};

    #[test]
    fn a_sheet_round_trips_through_the_codec() {
        let mut r = Robot::new(
            Timing::default(),
            Initial::StandBy,
            hans_codec::ProtocolLevel::V6,
        );
        r.update(0.0);
        let snap = r.snapshot(0.0);
        let sheet = sheet_of(&snap);
        let mut out = vec![0u8; 12 + DataSheet::MAX_JSON_LEN];
        let n = sheet.write_packet(&mut out).unwrap();
        let mut d = hans_codec::datasheet::Deframer::<8192>::new();
        let (_, item) = d.push(&out[..n]);
        let back = DataSheet::parse(item.unwrap().unwrap()).unwrap();
        assert_eq!(back, sheet);
        assert_eq!(back.state.robot_state, Some(hans_codec::FsmState::StandBy));
        let j = back.pos_and_vel.position.unwrap().joints;
        assert_eq!(j[2], Decimal::from_milli(90_000));
    }
}
