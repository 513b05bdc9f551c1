//! The machine's nodes under `Objects/Machines` (OPC 40001-1), in gonio's namespace with
//! string ids (`Machine/Monitoring/Phase`): `Identification` (a `MachineIdentificationType`
//! with the DI properties), the `Monitoring` folder ([`crate::monitoring`]'s variables) and
//! `ResultManagement` (a `ResultManagementType` with its four methods, whose arguments are
//! copied from the type's, and the `Results` folder). Every variable is read-only.
//!
//! The machine, `ResultManagement` and the server object are event notifiers: a client
//! subscribes to `ResultReadyEventType` on any of them.

use crate::Machine;
use crate::model::{self, GONIO};
use crate::monitoring::{VARS, Var};
use opcua::nodes::{
    AccessLevel, EventNotifier, MethodBuilder, NodeType, ObjectBuilder, VariableBuilder,
};
use opcua::server::address_space::AddressSpace;
use opcua::types::{
    Argument, DataEncoding, DataTypeId, EUInformation, ExtensionObject, LocalizedText, NodeId,
    NumericRange, ObjectId, ObjectTypeId, QualifiedName, ReferenceTypeId, TimestampsToReturn,
    VariableTypeId, Variant,
};

/// The method of `ResultManagementType` with its input and output arguments' property ids
/// (`Opc.Ua.Machinery.Result.NodeIds.csv`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ResultMethod {
    /// `GetLatestResult`.
    GetLatestResult,
    /// `GetResultById`.
    GetResultById,
    /// `GetResultIdListFiltered`.
    GetResultIdListFiltered,
    /// `ReleaseResultHandle`.
    ReleaseResultHandle,
}

impl ResultMethod {
    /// Every method.
    pub(crate) const ALL: [ResultMethod; 4] = [
        ResultMethod::GetLatestResult,
        ResultMethod::GetResultById,
        ResultMethod::GetResultIdListFiltered,
        ResultMethod::ReleaseResultHandle,
    ];

    /// The browse name (Result Transfer's namespace).
    pub(crate) fn name(self) -> &'static str {
        match self {
            ResultMethod::GetLatestResult => "GetLatestResult",
            ResultMethod::GetResultById => "GetResultById",
            ResultMethod::GetResultIdListFiltered => "GetResultIdListFiltered",
            ResultMethod::ReleaseResultHandle => "ReleaseResultHandle",
        }
    }

    /// The type's method and its argument properties.
    fn type_ids(self) -> (u32, u32, u32) {
        use model::result::*;
        match self {
            ResultMethod::GetLatestResult => (GET_LATEST_RESULT, 6054, 6055),
            ResultMethod::GetResultById => (GET_RESULT_BY_ID, 6048, 6049),
            ResultMethod::GetResultIdListFiltered => (GET_RESULT_ID_LIST_FILTERED, 6050, 6051),
            ResultMethod::ReleaseResultHandle => (RELEASE_RESULT_HANDLE, 6052, 6053),
        }
    }
}

/// The namespaces' indices in this server and the ids of the nodes the server uses.
#[derive(Debug, Clone)]
pub(crate) struct Ids {
    /// gonio's namespace.
    pub(crate) gonio: u16,
    /// DI's.
    pub(crate) di: u16,
    /// Machinery's.
    pub(crate) machinery: u16,
    /// Machinery Result Transfer's.
    pub(crate) result: u16,
    /// `ProcessingTimesDataType`.
    pub(crate) processing_times_type: NodeId,
    /// `ResultMetaDataType`.
    pub(crate) result_meta_data_type: NodeId,
    /// `ResultDataType`.
    pub(crate) result_data_type: NodeId,
    /// gonio's `MountingResultDataType`.
    pub(crate) mounting_result_type: NodeId,
    /// `ResultReadyEventType`.
    pub(crate) result_ready_event_type: NodeId,
    /// The machine.
    pub(crate) machine: NodeId,
    /// Its `ResultManagement`.
    pub(crate) result_management: NodeId,
    /// Its `ResultManagement/Results` folder.
    pub(crate) results: NodeId,
}

impl Ids {
    /// The ids in `space` (the NodeSets loaded into it).
    pub(crate) fn new(space: &AddressSpace) -> Result<Ids, String> {
        let ns = |uri: &str| {
            space
                .namespace_index(uri)
                .ok_or_else(|| format!("namespace {uri} not loaded"))
        };
        let (gonio, di, machinery, result) = (
            ns(GONIO)?,
            ns(model::DI)?,
            ns(model::MACHINERY)?,
            ns(model::RESULT)?,
        );
        let r = |i: u32| NodeId::new(result, i);
        let g = |s: &str| NodeId::new(gonio, s.to_string());
        Ok(Ids {
            gonio,
            di,
            machinery,
            result,
            processing_times_type: r(model::result::PROCESSING_TIMES_DATA_TYPE),
            result_meta_data_type: r(model::result::RESULT_META_DATA_TYPE),
            result_data_type: r(model::result::RESULT_DATA_TYPE),
            mounting_result_type: NodeId::new(gonio, model::gonio::MOUNTING_RESULT_DATA_TYPE),
            result_ready_event_type: r(model::result::RESULT_READY_EVENT_TYPE),
            machine: g("Machine"),
            result_management: g("Machine/ResultManagement"),
            results: g("Machine/ResultManagement/Results"),
        })
    }

    /// The structures the server sends.
    pub(crate) fn served_structures(&self) -> [NodeId; 4] {
        [
            self.processing_times_type.clone(),
            self.result_meta_data_type.clone(),
            self.result_data_type.clone(),
            self.mounting_result_type.clone(),
        ]
    }

    /// A `Monitoring` variable.
    pub(crate) fn monitoring_var(&self, name: &str) -> NodeId {
        NodeId::new(self.gonio, format!("Machine/Monitoring/{name}"))
    }

    /// A `ResultManagement` method.
    pub(crate) fn method(&self, m: ResultMethod) -> NodeId {
        NodeId::new(self.gonio, format!("Machine/ResultManagement/{}", m.name()))
    }

    /// The method a node id names, if it is one of `ResultManagement`'s.
    pub(crate) fn which_method(&self, id: &NodeId) -> Option<ResultMethod> {
        ResultMethod::ALL
            .into_iter()
            .find(|m| &self.method(*m) == id)
    }

    /// A result's variable in `Results` (`child`: a path below it, or empty).
    pub(crate) fn result_var(&self, result_id: &str, child: &str) -> NodeId {
        NodeId::new(
            self.gonio,
            format!("Machine/ResultManagement/Results/{result_id}{child}"),
        )
    }
}

/// Read-only for everyone.
fn read_only() -> AccessLevel {
    AccessLevel::CURRENT_READ
}

/// A property (`PropertyType`) of `parent`.
fn property(
    space: &mut AddressSpace,
    id: NodeId,
    name: QualifiedName,
    data_type: DataTypeId,
    value: Variant,
    parent: &NodeId,
) {
    let display = name.name.to_string();
    VariableBuilder::new(&id, name, display)
        .data_type(data_type)
        .value(value)
        .access_level(read_only())
        .user_access_level(read_only())
        .has_type_definition(VariableTypeId::PropertyType)
        .property_of(parent.clone())
        .insert(space);
}

/// The arguments of the type's method property `id` (Result Transfer's namespace).
fn type_arguments(space: &AddressSpace, ns: u16, id: u32) -> Result<Vec<Argument>, String> {
    let node = NodeId::new(ns, id);
    let Some(NodeType::Variable(v)) = space.find(&node) else {
        return Err(format!("no argument list {node}"));
    };
    let value = v.value(
        TimestampsToReturn::Neither,
        &NumericRange::None,
        &DataEncoding::Binary,
        0.0,
    );
    let Some(Variant::Array(a)) = value.value else {
        return Err(format!("{node} is not an argument list"));
    };
    a.values
        .into_iter()
        .map(|v| match v {
            Variant::ExtensionObject(o) => o
                .into_inner_as::<Argument>()
                .map(|a| *a)
                .ok_or_else(|| format!("{node}: not an Argument")),
            _ => Err(format!("{node}: not an Argument")),
        })
        .collect()
}

/// Builds the machine's nodes into `space` (where the NodeSets were loaded).
pub(crate) fn build(space: &mut AddressSpace, ids: &Ids, m: &Machine) -> Result<(), String> {
    let g = |s: &str| NodeId::new(ids.gonio, s.to_string());
    let machines = NodeId::new(ids.machinery, model::machinery::MACHINES);
    let notifier = EventNotifier::SUBSCRIBE_TO_EVENTS;

    ObjectBuilder::new(
        &ids.machine,
        QualifiedName::new(ids.gonio, m.station.as_str()),
        m.station.as_str(),
    )
    .description(format!(
        "The encoder-grating mounting station {} ({})",
        m.station,
        m.mode.name()
    ))
    .has_type_definition(ObjectTypeId::BaseObjectType)
    .event_notifier(notifier)
    .organized_by(machines)
    .insert(space);

    // Identification (OPC 40001-1 §8.6): DI's properties.
    let ident = g("Machine/Identification");
    ObjectBuilder::new(
        &ident,
        QualifiedName::new(ids.di, "Identification"),
        "Identification",
    )
    .has_type_definition(NodeId::new(
        ids.machinery,
        model::machinery::MACHINE_IDENTIFICATION_TYPE,
    ))
    .insert(space);
    space.insert_reference(&ids.machine, &ident, ReferenceTypeId::HasAddIn);
    let text = |s: &str| Variant::from(LocalizedText::new("en", s));
    for (name, data_type, value) in [
        (
            "Manufacturer",
            DataTypeId::LocalizedText,
            text(&m.manufacturer),
        ),
        ("Model", DataTypeId::LocalizedText, text(&m.model)),
        (
            "SerialNumber",
            DataTypeId::String,
            Variant::from(m.serial_number.as_str()),
        ),
        (
            "SoftwareRevision",
            DataTypeId::String,
            Variant::from(m.software_revision.as_str()),
        ),
        (
            "ProductInstanceUri",
            DataTypeId::String,
            Variant::from(m.product_instance_uri.as_str()),
        ),
    ] {
        property(
            space,
            g(&format!("Machine/Identification/{name}")),
            QualifiedName::new(ids.di, name),
            data_type,
            value,
            &ident,
        );
    }

    // Monitoring (OPC 40001-1 §12): a folder of the station's live values.
    let monitoring = g("Machine/Monitoring");
    ObjectBuilder::new(
        &monitoring,
        QualifiedName::new(ids.machinery, "Monitoring"),
        "Monitoring",
    )
    .is_folder()
    .component_of(ids.machine.clone())
    .insert(space);
    for v in VARS {
        monitoring_var(space, ids, &monitoring, v, m);
    }

    // ResultManagement (OPC 40001-101 §7.1).
    ObjectBuilder::new(
        &ids.result_management,
        QualifiedName::new(ids.result, "ResultManagement"),
        "ResultManagement",
    )
    .has_type_definition(NodeId::new(
        ids.result,
        model::result::RESULT_MANAGEMENT_TYPE,
    ))
    .event_notifier(notifier)
    .insert(space);
    space.insert_reference(
        &ids.machine,
        &ids.result_management,
        ReferenceTypeId::HasAddIn,
    );
    for method in ResultMethod::ALL {
        let (_, input, output) = method.type_ids();
        let id = ids.method(method);
        let (inputs, outputs) = (
            type_arguments(space, ids.result, input)?,
            type_arguments(space, ids.result, output)?,
        );
        let args = |kind: &str| {
            NodeId::new(
                ids.gonio,
                format!("Machine/ResultManagement/{}/{kind}", method.name()),
            )
        };
        let (input_id, output_id) = (args("InputArguments"), args("OutputArguments"));
        MethodBuilder::new(
            &id,
            QualifiedName::new(ids.result, method.name()),
            method.name(),
        )
        .component_of(ids.result_management.clone())
        .executable(true)
        .user_executable(true)
        .input_args(space, &input_id, &inputs)
        .output_args(space, &output_id, &outputs)
        .insert(space);
        for a in [&input_id, &output_id] {
            if let Some(NodeType::Variable(v)) = space.find_mut(a) {
                v.set_access_level(read_only());
                v.set_user_access_level(read_only());
            }
        }
    }
    ObjectBuilder::new(
        &ids.results,
        QualifiedName::new(ids.result, "Results"),
        "Results",
    )
    .is_folder()
    .component_of(ids.result_management.clone())
    .insert(space);

    // The machine is an event source of the server object (its ResultManagement, where the
    // events come from, is the machine's component already).
    let server = NodeId::from(ObjectId::Server);
    space.insert_reference(&server, &ids.machine, ReferenceTypeId::HasNotifier);
    Ok(())
}

/// One `Monitoring` variable (an `AnalogUnitType` with its `EngineeringUnits` for a
/// quantity), starting null (`StationMode`: the machine's mode).
fn monitoring_var(space: &mut AddressSpace, ids: &Ids, parent: &NodeId, v: Var, m: &Machine) {
    let id = ids.monitoring_var(v.name);
    let value = if v.name == "StationMode" {
        Variant::from(m.mode.name())
    } else {
        Variant::Empty
    };
    VariableBuilder::new(&id, QualifiedName::new(ids.gonio, v.name), v.name)
        .description(v.description)
        .data_type(v.data_type)
        .value(value)
        .access_level(read_only())
        .user_access_level(read_only())
        .has_type_definition(if v.unit.is_some() {
            VariableTypeId::AnalogUnitType
        } else {
            VariableTypeId::BaseDataVariableType
        })
        .component_of(parent.clone())
        .insert(space);
    if let Some(u) = v.unit {
        let eu = EUInformation {
            namespace_uri: "http://www.opcfoundation.org/UA/units/un/cefact".into(),
            unit_id: u.unit_id(),
            display_name: LocalizedText::new("en", u.symbol),
            description: LocalizedText::new("en", u.name),
        };
        property(
            space,
            NodeId::new(
                ids.gonio,
                format!("Machine/Monitoring/{}/EngineeringUnits", v.name),
            ),
            QualifiedName::new(0, "EngineeringUnits"),
            DataTypeId::EUInformation,
            Variant::from(ExtensionObject::from_message(eu)),
            &id,
        );
    }
}

/// Adds a result's variable to `Results`: a `ResultType` with the `ResultDataType` as its
/// value, its `ResultMetaData` and that one's `ResultId`.
pub(crate) fn add_result(
    space: &mut AddressSpace,
    ids: &Ids,
    result_id: &str,
    result: ExtensionObject,
    meta: ExtensionObject,
) {
    let var = ids.result_var(result_id, "");
    let meta_id = ids.result_var(result_id, "/ResultMetaData");
    let id_id = ids.result_var(result_id, "/ResultMetaData/ResultId");
    let structured = ReferenceTypeId::HasStructuredComponent;
    VariableBuilder::new(&var, QualifiedName::new(ids.gonio, result_id), result_id)
        .data_type(ids.result_data_type.clone())
        .value(Variant::from(result))
        .access_level(read_only())
        .user_access_level(read_only())
        .has_type_definition(NodeId::new(ids.result, model::result::RESULT_TYPE))
        .component_of(ids.results.clone())
        .insert(space);
    VariableBuilder::new(
        &meta_id,
        QualifiedName::new(ids.result, "ResultMetaData"),
        "ResultMetaData",
    )
    .data_type(ids.result_meta_data_type.clone())
    .value(Variant::from(meta))
    .access_level(read_only())
    .user_access_level(read_only())
    .has_type_definition(VariableTypeId::BaseDataVariableType)
    .insert(space);
    VariableBuilder::new(
        &id_id,
        QualifiedName::new(ids.result, "ResultId"),
        "ResultId",
    )
    .data_type(DataTypeId::TrimmedString)
    .value(Variant::from(result_id))
    .access_level(read_only())
    .user_access_level(read_only())
    .has_type_definition(VariableTypeId::BaseDataVariableType)
    .insert(space);
    space.insert_references(
        [(&var, &meta_id, structured), (&meta_id, &id_id, structured)].into_iter(),
    );
}

/// Removes a result's variable (and its children) from `Results`.
pub(crate) fn remove_result(space: &mut AddressSpace, ids: &Ids, result_id: &str) {
    let var = ids.result_var(result_id, "");
    let meta_id = ids.result_var(result_id, "/ResultMetaData");
    let id_id = ids.result_var(result_id, "/ResultMetaData/ResultId");
    for n in [id_id, meta_id, var] {
        space.delete(&n, true);
    }
}
