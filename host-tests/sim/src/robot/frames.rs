//! Section 4.8: the tool (TCP) and user (UCS) frames, current and named.
//! Frames cannot change while a motion is running (`Fail,20018`); unknown
//! names are `Fail,20029` (TCP) and `Fail,20030` (UCS).

use hans_codec::{request as rq, response as rs, TextList};

use super::dispatch::{done, values, Answer, Outcome, STATE};
use super::values::{decs, fs};
use super::Robot;
use crate::kinematics::{self as k, Frame, Pose, PoseFrame};

/// A tool frame name that does not exist.
const NO_TCP: i32 = 20029;
/// A user frame name that does not exist.
const NO_UCS: i32 = 20030;

impl Robot {
    /// The named tool frame.
    pub(super) fn tcp_named(&self, name: &str) -> Result<Pose, i32> {
        self.tcps.get(name).copied().ok_or(NO_TCP)
    }

    /// The named user frame.
    pub(super) fn ucs_named(&self, name: &str) -> Result<Pose, i32> {
        self.ucss.get(name).copied().ok_or(NO_UCS)
    }

    /// Frames stay as they are while a motion runs.
    fn need_still(&self) -> Result<(), i32> {
        if self.active.is_some() {
            Err(STATE)
        } else {
            Ok(())
        }
    }

    pub(super) fn set_cur_tcp(&mut self, c: &rq::SetCurTCP) -> Outcome<'_> {
        self.need_still()?;
        self.tcp = fs(c.tcp);
        done()
    }

    pub(super) fn set_cur_ucs(&mut self, c: &rq::SetCurUCS) -> Outcome<'_> {
        self.need_still()?;
        self.ucs = fs(c.ucs);
        done()
    }

    pub(super) fn set_tcp_by_name(&mut self, c: &rq::SetTCPByName) -> Outcome<'_> {
        let p = self.tcp_named(c.name)?;
        self.need_still()?;
        self.tcp = p;
        done()
    }

    pub(super) fn set_ucs_by_name(&mut self, c: &rq::SetUCSByName) -> Outcome<'_> {
        let p = self.ucs_named(c.name)?;
        self.need_still()?;
        self.ucs = p;
        done()
    }

    /// `SetDftTCP` (V6 document 4.8.11): a taught tool frame becomes the
    /// current one.
    pub(super) fn set_dft_tcp(&mut self, c: &rq::SetDftTCP) -> Outcome<'_> {
        let p = self.tcp_named(c.name)?;
        self.need_still()?;
        self.tcp = p;
        done()
    }

    pub(super) fn read_tcp_by_name(&self, c: &rq::ReadTCPByName) -> Outcome<'_> {
        values(rs::ReadTCPByName {
            tcp: decs(self.tcp_named(c.name)?),
        })
    }

    pub(super) fn read_ucs_by_name(&self, c: &rq::ReadUCSByName) -> Outcome<'_> {
        values(rs::ReadUCSByName {
            ucs: decs(self.ucs_named(c.name)?),
        })
    }

    // ------------------------------------------------ V6 document 4.8

    pub(super) fn config_tcp(&mut self, c: &rq::ConfigTCP) -> Outcome<'_> {
        self.tcps.insert(c.name.to_string(), fs(c.tcp));
        done()
    }

    pub(super) fn config_ucs(&mut self, c: &rq::ConfigUCS) -> Outcome<'_> {
        self.ucss.insert(c.name.to_string(), fs(c.ucs));
        done()
    }

    /// `CalTCPOrt`: the tool orientation that makes the TCP's axes those
    /// of the user frame, for the flange at `pcs`: `R_flangeᵀ·R_ucs`.
    pub(super) fn cal_tcp_ort(&self, c: &rq::CalTCPOrt) -> Outcome<'_> {
        let ucs = Frame::from_pose(&fs(c.ucs)).rotation;
        let flange = Frame::from_pose(&fs(c.pcs)).rotation;
        values(rs::CalTCPOrt {
            orientation: decs(k::rot_to_rpy(&(flange.inverse() * ucs))),
        })
    }

    /// `ReadTCPList`: the names of the tool frames (written here: the
    /// names are the robot's).
    pub(super) fn read_tcp_list(&self) -> Outcome<'static> {
        let names: Vec<&str> = self.tcps.keys().map(String::as_str).collect();
        Answer::encoded(rs::ReadTCPList {
            names: TextList::new(&names),
        })
    }
}
