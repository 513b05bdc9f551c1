//! The `Monitoring` folder's variables: their names (units in the names), data types, units
//! (OPC UA `EngineeringUnits`, UNECE codes) and how their values follow from the station's
//! latest state, the store's counters and the PLC link's figures. An undefined value (no e
//! measured yet, no PLC link) is a null value, never NaN.

use crate::feed::{LinkRoundTrips, Live};
use gonio_store::PartStats;
use opcua::types::{DataTypeId, Variant};

/// A unit: its UNECE common code, the symbol and its name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Unit {
    /// UNECE Recommendation 20 common code (`4H`: micrometre).
    pub(crate) code: &'static str,
    /// The symbol shown (`µm`).
    pub(crate) symbol: &'static str,
    /// The name (`micrometre`).
    pub(crate) name: &'static str,
}

impl Unit {
    /// The `UnitId` OPC UA derives from the common code (Part 8, §5.6.3): its characters'
    /// bytes, big-endian.
    pub(crate) fn unit_id(self) -> i32 {
        self.code
            .bytes()
            .fold(0i32, |id, b| (id << 8) | i32::from(b))
    }
}

const MICROMETRE: Unit = Unit {
    code: "4H",
    symbol: "µm",
    name: "micrometre",
};
const SECOND: Unit = Unit {
    code: "SEC",
    symbol: "s",
    name: "second",
};
const MILLISECOND: Unit = Unit {
    code: "C26",
    symbol: "ms",
    name: "millisecond",
};

/// One variable of `Monitoring`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Var {
    /// Browse name (gonio's namespace) and the last part of its node id.
    pub(crate) name: &'static str,
    /// Its data type.
    pub(crate) data_type: DataTypeId,
    /// Its unit, for a quantity (an `AnalogUnitType` variable).
    pub(crate) unit: Option<Unit>,
    /// What it is.
    pub(crate) description: &'static str,
}

/// Every variable, in the order they are browsed.
pub(crate) const VARS: [Var; 12] = [
    Var {
        name: "Phase",
        data_type: DataTypeId::String,
        unit: None,
        description: "What the station is doing: idle, focus, measure, push or verify.",
    },
    Var {
        name: "StationMode",
        data_type: DataTypeId::String,
        unit: None,
        description: "What runs the station: sim (the digital twin), plc, or none (only the results store is served).",
    },
    Var {
        name: "CurrentPartSerial",
        data_type: DataTypeId::String,
        unit: None,
        description: "The serial of the part being mounted (empty between parts).",
    },
    Var {
        name: "LastE_um",
        data_type: DataTypeId::Double,
        unit: Some(MICROMETRE),
        description: "The eccentricity of the last evaluated turn, µm (null: none yet in this part, or the ring was lost).",
    },
    Var {
        name: "LastU_um",
        data_type: DataTypeId::Double,
        unit: Some(MICROMETRE),
        description: "The standard uncertainty of LastE_um, µm (null: not defined).",
    },
    Var {
        name: "PartsDone",
        data_type: DataTypeId::UInt64,
        unit: None,
        description: "Parts of this station in the results store.",
    },
    Var {
        name: "PartsAccepted",
        data_type: DataTypeId::UInt64,
        unit: None,
        description: "Of PartsDone, those accepted.",
    },
    Var {
        name: "PartsRejected",
        data_type: DataTypeId::UInt64,
        unit: None,
        description: "Of PartsDone, those rejected (for any reason).",
    },
    Var {
        name: "MeanCycleTime_s",
        data_type: DataTypeId::Double,
        unit: Some(SECOND),
        description: "Mean station time per part over PartsDone, s (null without parts).",
    },
    Var {
        name: "LinkRequests",
        data_type: DataTypeId::UInt64,
        unit: None,
        description: "Modbus requests to the station's PLC timed so far (null without a PLC).",
    },
    Var {
        name: "LinkRoundTripP50_ms",
        data_type: DataTypeId::Double,
        unit: Some(MILLISECOND),
        description: "Median round trip of a Modbus request to the PLC, ms (null without a PLC).",
    },
    Var {
        name: "LinkRoundTripP99_ms",
        data_type: DataTypeId::Double,
        unit: Some(MILLISECOND),
        description: "99th percentile round trip of a Modbus request to the PLC, ms (null without a PLC).",
    },
];

/// A number, or null.
fn num(x: Option<f64>) -> Variant {
    match x {
        Some(v) if v.is_finite() => Variant::Double(v),
        _ => Variant::Empty,
    }
}

/// The values of the variables fed by the station's state, by name.
pub(crate) fn live_values(live: &Live) -> [(&'static str, Variant); 4] {
    [
        ("Phase", Variant::from(live.phase.name())),
        (
            "CurrentPartSerial",
            Variant::from(live.serial.as_deref().unwrap_or("")),
        ),
        ("LastE_um", num(live.last_e_um)),
        ("LastU_um", num(live.last_u_um)),
    ]
}

/// The values of the counters, from the store's statistics of this station's parts.
pub(crate) fn counter_values(s: &PartStats) -> [(&'static str, Variant); 4] {
    [
        ("PartsDone", Variant::UInt64(s.parts)),
        ("PartsAccepted", Variant::UInt64(s.pass)),
        ("PartsRejected", Variant::UInt64(s.reject)),
        ("MeanCycleTime_s", num(s.mean_time_s)),
    ]
}

/// The values of the link's figures.
pub(crate) fn link_values(l: Option<LinkRoundTrips>) -> [(&'static str, Variant); 3] {
    [
        (
            "LinkRequests",
            l.map_or(Variant::Empty, |l| Variant::UInt64(l.requests)),
        ),
        ("LinkRoundTripP50_ms", num(l.map(|l| l.round_trip_p50_ms))),
        ("LinkRoundTripP99_ms", num(l.map(|l| l.round_trip_p99_ms))),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::feed::LivePhase;

    #[test]
    fn unit_ids_follow_the_unece_codes() {
        // OPC 10000-8's examples: micrometre "4H" = 0x3448, second "SEC" = 0x534543.
        assert_eq!(MICROMETRE.unit_id(), 0x3448);
        assert_eq!(SECOND.unit_id(), 5457219);
        assert_eq!(MILLISECOND.unit_id(), 0x433236);
    }

    #[test]
    fn every_value_names_a_variable_and_quantities_carry_their_unit_in_the_name() {
        let live = Live {
            phase: LivePhase::Push,
            serial: Some("S-1".into()),
            last_e_um: Some(12.5),
            last_u_um: None,
        };
        let stats = PartStats {
            parts: 3,
            pass: 2,
            reject: 1,
            mean_time_s: Some(9.5),
            mean_pushes: None,
            max_pushes: None,
            mean_final_e_um: None,
        };
        let names: Vec<&str> = live_values(&live)
            .iter()
            .map(|v| v.0)
            .chain(counter_values(&stats).iter().map(|v| v.0))
            .chain(link_values(None).iter().map(|v| v.0))
            .chain(["StationMode"])
            .collect();
        let mut all: Vec<&str> = VARS.iter().map(|v| v.name).collect();
        let mut got = names.clone();
        all.sort_unstable();
        got.sort_unstable();
        assert_eq!(got, all, "each variable has exactly one source");
        for v in VARS {
            if let Some(u) = v.unit {
                assert!(
                    v.name.ends_with(&format!("_{}", u.code_suffix())),
                    "{}",
                    v.name
                );
            }
        }
        assert_eq!(live_values(&live)[0].1, Variant::from("push"));
        assert_eq!(live_values(&live)[3].1, Variant::Empty, "undefined is null");
        assert_eq!(counter_values(&stats)[2].1, Variant::UInt64(1));
        assert_eq!(link_values(None)[1].1, Variant::Empty);
    }

    impl Unit {
        /// The suffix a variable's name ends with for this unit.
        fn code_suffix(self) -> &'static str {
            match self.symbol {
                "µm" => "um",
                s => s,
            }
        }
    }
}
