//! An XDND drag source for the window tests: drops files on a window as a file manager
//! does (xdotool cannot drag between clients). The protocol, as the source sees it:
//! own XdndSelection, send XdndEnter (offering text/uri-list) and XdndPosition to the
//! target, answer its SelectionRequest with the file URIs, wait for its XdndStatus, send
//! XdndDrop, and wait for XdndFinished.
//!
//! winit asks for the data on XdndPosition, not on XdndDrop, and reports the drop only if
//! that answer reached it first; answering before sending XdndDrop keeps the order (the
//! server delivers one client's requests in order).

use std::path::Path;
use std::time::{Duration, Instant};

use x11rb::connection::Connection;
use x11rb::protocol::xproto::{
    Atom, AtomEnum, ClientMessageEvent, ConnectionExt as _, CreateWindowAux, EventMask, PropMode,
    SelectionNotifyEvent, Window, WindowClass, SELECTION_NOTIFY_EVENT,
};
use x11rb::protocol::Event;
use x11rb::rust_connection::RustConnection;
use x11rb::wrapper::ConnectionExt as _;
use x11rb::{COPY_DEPTH_FROM_PARENT, CURRENT_TIME};

/// The XDND version this source speaks (winit's too).
const VERSION: u32 = 5;

/// The atoms the protocol names.
struct Atoms {
    aware: Atom,
    selection: Atom,
    enter: Atom,
    position: Atom,
    status: Atom,
    drop: Atom,
    finished: Atom,
    action_copy: Atom,
    uri_list: Atom,
}

impl Atoms {
    fn new(conn: &RustConnection) -> Result<Self, String> {
        let atom = |name: &str| -> Result<Atom, String> {
            let cookie = conn
                .intern_atom(false, name.as_bytes())
                .map_err(|e| format!("intern {name}: {e}"))?;
            Ok(cookie.reply().map_err(|e| format!("intern {name}: {e}"))?.atom)
        };
        Ok(Self {
            aware: atom("XdndAware")?,
            selection: atom("XdndSelection")?,
            enter: atom("XdndEnter")?,
            position: atom("XdndPosition")?,
            status: atom("XdndStatus")?,
            drop: atom("XdndDrop")?,
            finished: atom("XdndFinished")?,
            action_copy: atom("XdndActionCopy")?,
            uri_list: atom("text/uri-list")?,
        })
    }
}

/// What the target said to the drop.
#[derive(Debug, PartialEq, Eq)]
pub struct DropOutcome {
    /// XdndStatus accepted the drag (the target takes text/uri-list).
    pub accepted: bool,
    /// XdndFinished reported the drop as performed.
    pub finished_ok: bool,
    /// The target asked for the data (SelectionRequest) at least once.
    pub data_requested: bool,
}

/// Drop `files` (absolute paths) on `target` (a window id, decimal as xdotool prints it)
/// of the X server `display`. Errors are one sentence: no XdndAware, no answer in `timeout`.
pub fn drop_files(
    display: &str,
    target: &str,
    files: &[&Path],
    timeout: Duration,
) -> Result<DropOutcome, String> {
    let target: Window =
        target.trim().parse().map_err(|_| format!("{target:?} is not a window id"))?;
    let (conn, screen) =
        x11rb::connect(Some(display)).map_err(|e| format!("cannot connect to {display}: {e}"))?;
    let root = conn.setup().roots[screen].root;
    let atoms = Atoms::new(&conn)?;
    let x = |e: &dyn std::fmt::Display| format!("X request failed: {e}");

    // The target must say it takes drops, and which version.
    let aware = conn
        .get_property(false, target, atoms.aware, AtomEnum::ATOM, 0, 1)
        .map_err(|e| x(&e))?
        .reply()
        .map_err(|e| x(&e))?;
    let version = aware
        .value32()
        .and_then(|mut v| v.next())
        .ok_or_else(|| format!("window {target} is not XdndAware"))?;
    let version = version.min(VERSION);

    // The source: an unmapped window that owns the selection and receives the answers.
    let source = conn.generate_id().map_err(|e| x(&e))?;
    conn.create_window(
        COPY_DEPTH_FROM_PARENT,
        source,
        root,
        0,
        0,
        1,
        1,
        0,
        WindowClass::INPUT_OUTPUT,
        0,
        &CreateWindowAux::new(),
    )
    .map_err(|e| x(&e))?;
    conn.set_selection_owner(source, atoms.selection, CURRENT_TIME).map_err(|e| x(&e))?;

    let mut uris = String::new();
    for f in files {
        uris.push_str(&format!("file://{}\r\n", f.display()));
    }

    // The target's centre in root coordinates (XdndPosition carries them).
    let geometry = conn.get_geometry(target).map_err(|e| x(&e))?.reply().map_err(|e| x(&e))?;
    let centre = conn
        .translate_coordinates(
            target,
            root,
            (geometry.width / 2) as i16,
            (geometry.height / 2) as i16,
        )
        .map_err(|e| x(&e))?
        .reply()
        .map_err(|e| x(&e))?;
    let packed = ((centre.dst_x as u16 as u32) << 16) | centre.dst_y as u16 as u32;

    let send = |type_: Atom, data: [u32; 5]| -> Result<(), String> {
        let event = ClientMessageEvent::new(32, target, type_, data);
        // No event mask: the event goes to the client that created the target window.
        conn.send_event(false, target, EventMask::NO_EVENT, event).map_err(|e| x(&e))?;
        conn.flush().map_err(|e| x(&e))
    };
    send(atoms.enter, [source, version << 24, atoms.uri_list, 0, 0])?;
    send(atoms.position, [source, 0, packed, CURRENT_TIME, atoms.action_copy])?;

    let mut outcome = DropOutcome { accepted: false, finished_ok: false, data_requested: false };
    let deadline = Instant::now() + timeout;
    let mut status = false;
    let mut dropped = false;
    loop {
        let event = conn.poll_for_event().map_err(|e| x(&e))?;
        let Some(event) = event else {
            if Instant::now() > deadline {
                let waiting = if !status {
                    "XdndStatus"
                } else if !dropped {
                    "the data request"
                } else {
                    "XdndFinished"
                };
                return Err(format!("no {waiting} from window {target} within {timeout:?}"));
            }
            std::thread::sleep(Duration::from_millis(10));
            continue;
        };
        match event {
            Event::SelectionRequest(req) if req.selection == atoms.selection => {
                // The URIs, as the type asked for (winit reads the property as text/uri-list).
                conn.change_property8(
                    PropMode::REPLACE,
                    req.requestor,
                    req.property,
                    req.target,
                    uris.as_bytes(),
                )
                .map_err(|e| x(&e))?;
                let notify = SelectionNotifyEvent {
                    response_type: SELECTION_NOTIFY_EVENT,
                    sequence: 0,
                    time: req.time,
                    requestor: req.requestor,
                    selection: req.selection,
                    target: req.target,
                    property: req.property,
                };
                conn.send_event(false, req.requestor, EventMask::NO_EVENT, notify)
                    .map_err(|e| x(&e))?;
                conn.flush().map_err(|e| x(&e))?;
                outcome.data_requested = true;
            }
            Event::ClientMessage(m) if m.type_ == atoms.status => {
                let data = m.data.as_data32();
                status = true;
                outcome.accepted = data[1] & 1 == 1;
                if !outcome.accepted {
                    return Ok(outcome);
                }
            }
            Event::ClientMessage(m) if m.type_ == atoms.finished => {
                outcome.finished_ok = version < 5 || m.data.as_data32()[1] & 1 == 1;
                return Ok(outcome);
            }
            _ => {}
        }
        // Drop once the target accepted and has the data (see the module's note).
        if status && outcome.data_requested && !dropped {
            dropped = true;
            send(atoms.drop, [source, 0, CURRENT_TIME, 0, 0])?;
        }
    }
}
