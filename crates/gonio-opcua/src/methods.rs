//! `ResultManagement`'s methods (OPC 40001-101 §7.1), reading results from the store.
//!
//! - `GetLatestResult(Timeout)`: this station's newest result;
//! - `GetResultById(ResultId, Timeout)`: any result of the store (`<station>/<part id>`), of
//!   this station or another of the fleet;
//! - `GetResultIdListFiltered(Filter, OrderedBy, MaxResults, Timeout)`: the ids of this
//!   station's results that pass the filter ([`crate::filter`]), oldest first; with
//!   `MaxResults` > 0 the newest that many, otherwise at most [`MAX_IDS`];
//! - `ReleaseResultHandle(ResultHandle)`: forgets a handle.
//!
//! Each call that returns results gives a new handle (the server keeps the
//! [`MAX_HANDLES`] newest). `Timeout` is a hint the server does not need: results stay in the
//! store. `Error` is 0, or one of the application-specific codes below.

use crate::codec::Codec;
use crate::filter::Filter;
use crate::node_manager::Shared;
use crate::result::{self, parse_result_id};
use gonio_store::{PartQuery, StoredPart};
use opcua::types::{ExtensionObject, StatusCode, UAString, Variant, VariantScalarTypeId};
use std::collections::VecDeque;

/// `Error`: no such result (none yet, or an unknown id).
pub const ERROR_NOT_FOUND: i32 = -1;
/// `Error`: the handle is not one the server gave out (or it was released).
pub const ERROR_UNKNOWN_HANDLE: i32 = -2;
/// `Error`: the results store failed.
pub const ERROR_STORE: i32 = -3;
/// `Error`: a result id not of the form `<station>/<part id>`.
pub const ERROR_BAD_ID: i32 = -4;
/// `Error`: a filter or ordering the server does not support.
pub const ERROR_UNSUPPORTED: i32 = -5;
/// `Error`: more results matched than [`MAX_IDS`]; the newest `MAX_IDS` are returned.
pub const ERROR_TRUNCATED: i32 = -6;

/// Most result ids returned by one `GetResultIdListFiltered` without `MaxResults`.
pub const MAX_IDS: usize = 10_000;
/// Result handles remembered.
pub const MAX_HANDLES: usize = 10_000;
/// Parts read from the store at a time while filtering.
const PAGE: usize = 200;

/// The handles given out, oldest first.
#[derive(Debug, Default)]
pub(crate) struct Handles {
    next: u32,
    open: VecDeque<u32>,
}

impl Handles {
    /// A new handle (never 0).
    fn issue(&mut self) -> u32 {
        self.next = self.next.wrapping_add(1).max(1);
        if self.open.len() == MAX_HANDLES {
            self.open.pop_front();
        }
        self.open.push_back(self.next);
        self.next
    }

    /// Forgets `h`; whether it was given out.
    fn release(&mut self, h: u32) -> bool {
        match self.open.iter().position(|x| *x == h) {
            Some(i) => {
                self.open.remove(i);
                true
            }
            None => false,
        }
    }
}

/// Why a call failed as a whole.
pub(crate) enum CallError {
    /// A status for the call.
    Status(StatusCode),
    /// One status per input argument (a wrong type).
    Arguments(Vec<StatusCode>),
}

/// Each argument's status: `Good`, or `BadTypeMismatch` where `ok` says no.
fn check(args: &[Variant], ok: &[fn(&Variant) -> bool]) -> Result<(), CallError> {
    let statuses: Vec<StatusCode> = args
        .iter()
        .zip(ok)
        .map(|(a, f)| {
            if f(a) {
                StatusCode::Good
            } else {
                StatusCode::BadTypeMismatch
            }
        })
        .collect();
    if statuses.iter().all(|s| s.is_good()) {
        Ok(())
    } else {
        Err(CallError::Arguments(statuses))
    }
}

fn is_int32(v: &Variant) -> bool {
    matches!(v, Variant::Int32(_))
}
fn is_uint32(v: &Variant) -> bool {
    matches!(v, Variant::UInt32(_))
}
fn is_string(v: &Variant) -> bool {
    matches!(v, Variant::String(_))
}
fn is_any(_: &Variant) -> bool {
    true
}

/// `[ResultHandle, Result, Error]`.
fn with_result(handle: u32, result: ExtensionObject, error: i32) -> Vec<Variant> {
    vec![
        Variant::UInt32(handle),
        Variant::from(result),
        Variant::Int32(error),
    ]
}

/// Calls `method` with `args` (their count already checked by the server).
pub(crate) async fn call(
    shared: &Shared,
    codec: &Codec,
    method: crate::machine::ResultMethod,
    args: &[Variant],
) -> Result<Vec<Variant>, CallError> {
    use crate::machine::ResultMethod as M;
    match method {
        M::GetLatestResult => {
            check(args, &[is_int32])?;
            let station = shared.machine.station.clone();
            let part = shared
                .stores
                .with(move |s| {
                    Ok(s.parts(&PartQuery {
                        station: Some(station),
                        limit: Some(1),
                        ..PartQuery::default()
                    })?
                    .pop())
                })
                .await;
            Ok(found(shared, codec, part))
        }
        M::GetResultById => {
            check(args, &[is_string, is_int32])?;
            let Variant::String(id) = &args[0] else {
                return Err(CallError::Status(StatusCode::BadTypeMismatch));
            };
            let Some((station, part)) = parse_result_id(id.as_ref()) else {
                return Ok(with_result(0, ExtensionObject::null(), ERROR_BAD_ID));
            };
            let station = station.to_string();
            let part = shared
                .stores
                .with(move |s| Ok(s.part(part)?.filter(|p| p.station == station)))
                .await;
            Ok(found(shared, codec, part))
        }
        M::GetResultIdListFiltered => {
            check(args, &[is_any, is_any, is_uint32, is_int32])?;
            let filter = match Filter::parse(&args[0], shared.ids.result) {
                Ok(f) => f,
                Err(_) => return Ok(id_list(0, vec![], ERROR_UNSUPPORTED)),
            };
            if !ordered_by_creation(&args[1], shared.ids.result) {
                return Ok(id_list(0, vec![], ERROR_UNSUPPORTED));
            }
            let Variant::UInt32(max) = args[2] else {
                return Err(CallError::Status(StatusCode::BadTypeMismatch));
            };
            let keep = if max == 0 { MAX_IDS } else { max as usize };
            let station = shared.machine.station.clone();
            let listed = shared
                .stores
                .with(move |s| {
                    let mut ids: VecDeque<String> = VecDeque::new();
                    let (mut matched, mut bad) = (0usize, None);
                    let q = PartQuery {
                        station: Some(station),
                        ..PartQuery::default()
                    };
                    s.for_each_page(&q, PAGE, &mut |page: Vec<StoredPart>| {
                        for p in &page {
                            match result::meta_fields(p) {
                                Ok(f) if filter.matches(&f) => {
                                    matched += 1;
                                    if ids.len() == keep {
                                        ids.pop_front();
                                    }
                                    ids.push_back(result::result_id(p));
                                }
                                Ok(_) => {}
                                Err(e) => bad = Some(e),
                            }
                        }
                        true
                    })?;
                    Ok((ids, matched, bad))
                })
                .await;
            Ok(match listed {
                Ok((_, _, Some(_))) | Err(_) => id_list(0, vec![], ERROR_STORE),
                Ok((ids, matched, None)) => {
                    let error = if max == 0 && matched > MAX_IDS {
                        ERROR_TRUNCATED
                    } else {
                        0
                    };
                    let h = issue(shared);
                    id_list(h, ids.into(), error)
                }
            })
        }
        M::ReleaseResultHandle => {
            check(args, &[is_uint32])?;
            let Variant::UInt32(h) = args[0] else {
                return Err(CallError::Status(StatusCode::BadTypeMismatch));
            };
            let known = shared
                .handles
                .lock()
                .map(|mut hs| hs.release(h))
                .unwrap_or(false);
            Ok(vec![Variant::Int32(if known {
                0
            } else {
                ERROR_UNKNOWN_HANDLE
            })])
        }
    }
}

/// A new result handle.
fn issue(shared: &Shared) -> u32 {
    shared.handles.lock().map(|mut h| h.issue()).unwrap_or(0)
}

/// The outputs of a call that looked up one part.
fn found(
    shared: &Shared,
    codec: &Codec,
    part: Result<Option<StoredPart>, gonio_store::StoreError>,
) -> Vec<Variant> {
    match part {
        Ok(Some(p)) => match result::result_data(codec, &p) {
            Ok(r) => with_result(issue(shared), r, 0),
            Err(_) => with_result(0, ExtensionObject::null(), ERROR_STORE),
        },
        Ok(None) => with_result(0, ExtensionObject::null(), ERROR_NOT_FOUND),
        Err(_) => with_result(0, ExtensionObject::null(), ERROR_STORE),
    }
}

/// `[ResultHandle, ResultIdList, Error]`.
fn id_list(handle: u32, ids: Vec<String>, error: i32) -> Vec<Variant> {
    let list: Vec<Variant> = ids
        .into_iter()
        .map(|s| Variant::String(UAString::from(s)))
        .collect();
    vec![
        Variant::UInt32(handle),
        Variant::from((VariantScalarTypeId::String, list)),
        Variant::Int32(error),
    ]
}

/// Whether `OrderedBy` asks for the order the server gives (creation time, or nothing).
fn ordered_by_creation(arg: &Variant, result_ns: u16) -> bool {
    let Variant::Array(a) = arg else {
        return matches!(arg, Variant::Empty);
    };
    a.values.iter().all(|v| {
        let Variant::ExtensionObject(o) = v else {
            return false;
        };
        let Some(path) = o.inner_as::<opcua::types::RelativePath>() else {
            return false;
        };
        let names: Vec<&str> = path
            .elements
            .as_deref()
            .unwrap_or_default()
            .iter()
            .filter(|e| e.target_name.namespace_index == result_ns)
            .map(|e| e.target_name.name.as_ref())
            .collect();
        let n = path.elements.as_deref().map_or(0, |e| e.len());
        names.len() == n
            && matches!(
                names.as_slice(),
                ["CreationTime"] | ["ResultMetaData", "CreationTime"]
            )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn handles_are_unique_bounded_and_released_once() {
        let mut h = Handles::default();
        let a = h.issue();
        let b = h.issue();
        assert!(a != 0 && b != 0 && a != b);
        assert!(h.release(a));
        assert!(!h.release(a), "released once");
        for _ in 0..MAX_HANDLES + 5 {
            h.issue();
        }
        assert_eq!(h.open.len(), MAX_HANDLES);
        assert!(!h.release(b), "the oldest are forgotten");
    }
}
