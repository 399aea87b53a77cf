//! Assembly object (class 0x04): the device's I/O data as instances.
//! Attribute 3 is the data (Get on every assembly, Set on output and
//! configuration assemblies), attribute 4 its size in bytes.

use super::{class_level, no_data, Outcome};
use crate::app::{Application, WriteOrigin};
use crate::device::{AssemblyKind, Device};
use crate::wire::cip::{AppPath, GeneralStatus, Request, Service};
use crate::wire::Writer;

/// The class revision.
const REVISION: u16 = 2;

/// Serves a request to the Assembly class or one of its instances. `owned`
/// tells whether an exclusive-owner connection writes an output assembly:
/// such an assembly refuses explicit writes (device state conflict).
pub(crate) fn handle<A: Application>(
    req: &Request<'_>,
    path: &AppPath,
    device: &Device<'_>,
    owned: &dyn Fn(u16) -> bool,
    app: &mut A,
    w: &mut Writer<'_>,
) -> Outcome {
    if path.instance == 0 {
        let max = device
            .assemblies
            .iter()
            .map(|a| a.instance)
            .max()
            .unwrap_or(0);
        return class_level(req, path, REVISION, max, w);
    }
    let asm = u16::try_from(path.instance)
        .ok()
        .and_then(|i| device.assembly(i))
        .ok_or(GeneralStatus::ObjectDoesNotExist)?;
    let attr = path
        .attribute
        .ok_or(GeneralStatus::PathDestinationUnknown)?;
    match (req.service, attr) {
        (Service::GetAttributeSingle, 3) => {
            no_data(req)?;
            let buf = w.reserve(usize::from(asm.size), "assembly data")?;
            app.read_assembly(asm.instance, buf);
            Ok(())
        }
        (Service::GetAttributeSingle, 4) => {
            no_data(req)?;
            w.u16(asm.size, "assembly size")?;
            Ok(())
        }
        (Service::GetAttributeSingle, _) => Err(GeneralStatus::AttributeNotSupported.into()),
        (Service::SetAttributeSingle, 3) => {
            if asm.kind == AssemblyKind::Input {
                return Err(GeneralStatus::AttributeNotSettable.into());
            }
            if owned(asm.instance) {
                return Err(GeneralStatus::DeviceStateConflict.into());
            }
            let size = usize::from(asm.size);
            if req.data.len() < size {
                return Err(GeneralStatus::NotEnoughData.into());
            }
            if req.data.len() > size {
                return Err(GeneralStatus::TooMuchData.into());
            }
            app.write_assembly(asm.instance, req.data, WriteOrigin::Explicit)?;
            Ok(())
        }
        (Service::SetAttributeSingle, 4) => Err(GeneralStatus::AttributeNotSettable.into()),
        (Service::SetAttributeSingle, _) => Err(GeneralStatus::AttributeNotSupported.into()),
        _ => Err(GeneralStatus::ServiceNotSupported.into()),
    }
}
