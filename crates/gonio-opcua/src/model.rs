//! The information model: the companion specifications' NodeSets, copied unchanged with their
//! licence headers into `nodesets/` (OPC 10000-100 DI 1.04.0, OPC 40001-1 Machinery 1.03.0,
//! OPC 40001-101 Machinery Result Transfer 1.00.0) and gonio's own
//! (`Gonio.Station.NodeSet2.xml`: the structure of a mounted part's result), built into the
//! binary and loaded into the server's address space at start by `async-opcua`'s NodeSet2
//! importer.
//!
//! Loaded at run time rather than turned into Rust by the crate's code generator: the import
//! takes about a tenth of a second at start, while generated code for the three models would
//! add tens of thousands of lines to every build of the workspace. The types, methods and
//! arguments the server uses are taken from the loaded nodes (the methods' arguments, the
//! structures' fields and encodings), and the numeric ids below are checked against the
//! specifications' `NodeIds.csv` by this module's tests.
//!
//! ```
//! let imports = gonio_opcua::model::imports().unwrap();
//! assert_eq!(imports.len(), 4);
//! ```

use crate::OpcUaError;
use opcua::nodes::{ImportedItem, NodeSet2Import, NodeSetImport, NodeSetNamespaceMapper};

/// OPC 10000-100 Devices (DI).
pub const DI: &str = "http://opcfoundation.org/UA/DI/";
/// OPC 40001-1 Machinery.
pub const MACHINERY: &str = "http://opcfoundation.org/UA/Machinery/";
/// OPC 40001-101 Machinery Result Transfer.
pub const RESULT: &str = "http://opcfoundation.org/UA/Machinery/Result/";
/// gonio's namespace: its result structure (from its NodeSet) and the machine's nodes.
pub const GONIO: &str = "urn:gonio:ua:station";

/// The NodeSets, in the order they are loaded (each needs only those before it), with the
/// namespaces they need that they do not list themselves.
const NODESETS: [(&str, &str); 4] = [
    (
        "Opc.Ua.Di.NodeSet2.xml",
        include_str!("../nodesets/Opc.Ua.Di.NodeSet2.xml"),
    ),
    (
        "Opc.Ua.Machinery.NodeSet2.xml",
        include_str!("../nodesets/Opc.Ua.Machinery.NodeSet2.xml"),
    ),
    (
        "Opc.Ua.Machinery.Result.NodeSet2.xml",
        include_str!("../nodesets/Opc.Ua.Machinery.Result.NodeSet2.xml"),
    ),
    (
        "Gonio.Station.NodeSet2.xml",
        include_str!("../nodesets/Gonio.Station.NodeSet2.xml"),
    ),
];

/// Numeric ids of the Machinery namespace (`Opc.Ua.Machinery.NodeIds.csv`).
pub mod machinery {
    /// `Objects/Machines`, the folder of every machine.
    pub const MACHINES: u32 = 1001;
    /// `MachineIdentificationType`.
    pub const MACHINE_IDENTIFICATION_TYPE: u32 = 1012;
}

/// Numeric ids of the Machinery Result Transfer namespace
/// (`Opc.Ua.Machinery.Result.NodeIds.csv`).
pub mod result {
    /// `ResultReadyEventType`.
    pub const RESULT_READY_EVENT_TYPE: u32 = 1002;
    /// `ResultManagementType`.
    pub const RESULT_MANAGEMENT_TYPE: u32 = 1004;
    /// `ResultType` (a variable type).
    pub const RESULT_TYPE: u32 = 2001;
    /// `ResultEvaluationEnum`.
    pub const RESULT_EVALUATION_ENUM: u32 = 3002;
    /// `ProcessingTimesDataType`.
    pub const PROCESSING_TIMES_DATA_TYPE: u32 = 3006;
    /// `ResultMetaDataType`.
    pub const RESULT_META_DATA_TYPE: u32 = 3007;
    /// `ResultDataType`.
    pub const RESULT_DATA_TYPE: u32 = 3008;
    /// `ResultManagementType/GetResultById`.
    pub const GET_RESULT_BY_ID: u32 = 7005;
    /// `ResultManagementType/GetResultIdListFiltered`.
    pub const GET_RESULT_ID_LIST_FILTERED: u32 = 7006;
    /// `ResultManagementType/ReleaseResultHandle`.
    pub const RELEASE_RESULT_HANDLE: u32 = 7007;
    /// `ResultManagementType/GetLatestResult`.
    pub const GET_LATEST_RESULT: u32 = 7008;
}

/// Numeric ids of gonio's namespace (`Gonio.Station.NodeSet2.xml`).
pub mod gonio {
    /// `MountingResultDataType`: a mounted part's result.
    pub const MOUNTING_RESULT_DATA_TYPE: u32 = 3001;
}

/// A NodeSet importer that registers its namespaces without printing (the crate's own
/// `register_namespaces` prints a line for each to standard output; a library of gonio
/// never prints). Loading is the crate's.
struct Import {
    inner: NodeSet2Import,
}

impl NodeSetImport for Import {
    fn register_namespaces(&self, namespaces: &mut NodeSetNamespaceMapper) {
        // A NodeSet's index n (n ≥ 1) is the n-th URI of its NamespaceUris; 0 is the base.
        for (i, ns) in self.inner.get_own_namespaces().iter().enumerate() {
            namespaces.add_namespace(ns, i as u16 + 1);
        }
    }

    fn get_own_namespaces(&self) -> Vec<String> {
        self.inner.get_own_namespaces()
    }

    fn load<'a>(
        &'a self,
        namespaces: &'a NodeSetNamespaceMapper,
    ) -> Box<dyn Iterator<Item = ImportedItem> + 'a> {
        self.inner.load(namespaces)
    }
}

/// The four NodeSets, parsed, in load order.
///
/// # Errors
/// [`OpcUaError::Model`] when one does not parse (a damaged build).
pub fn imports() -> Result<Vec<Box<dyn NodeSetImport>>, OpcUaError> {
    NODESETS
        .iter()
        .map(|(file, xml)| {
            let inner =
                NodeSet2Import::new_str("en", xml, Vec::new()).map_err(|e| OpcUaError::Model {
                    file,
                    message: e.to_string(),
                })?;
            Ok(Box::new(Import { inner }) as Box<dyn NodeSetImport>)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The id of `name` in a specification's `NodeIds.csv` (`Name,Id,NodeClass` rows).
    fn csv_id(csv: &str, name: &str) -> u32 {
        csv.lines()
            .filter_map(|l| {
                let mut f = l.split(',');
                Some((f.next()?, f.next()?.parse::<u32>().ok()?))
            })
            .find(|(n, _)| *n == name)
            .unwrap_or_else(|| panic!("{name} is not in the NodeIds.csv"))
            .1
    }

    #[test]
    fn the_ids_used_are_the_specifications_ids() {
        let m = include_str!("../nodesets/Opc.Ua.Machinery.NodeIds.csv");
        assert_eq!(csv_id(m, "Machines"), machinery::MACHINES);
        assert_eq!(
            csv_id(m, "MachineIdentificationType"),
            machinery::MACHINE_IDENTIFICATION_TYPE
        );
        let r = include_str!("../nodesets/Opc.Ua.Machinery.Result.NodeIds.csv");
        for (name, id) in [
            ("ResultReadyEventType", result::RESULT_READY_EVENT_TYPE),
            ("ResultManagementType", result::RESULT_MANAGEMENT_TYPE),
            ("ResultType", result::RESULT_TYPE),
            ("ResultEvaluationEnum", result::RESULT_EVALUATION_ENUM),
            (
                "ProcessingTimesDataType",
                result::PROCESSING_TIMES_DATA_TYPE,
            ),
            ("ResultMetaDataType", result::RESULT_META_DATA_TYPE),
            ("ResultDataType", result::RESULT_DATA_TYPE),
            (
                "ResultManagementType_GetResultById",
                result::GET_RESULT_BY_ID,
            ),
            (
                "ResultManagementType_GetResultIdListFiltered",
                result::GET_RESULT_ID_LIST_FILTERED,
            ),
            (
                "ResultManagementType_ReleaseResultHandle",
                result::RELEASE_RESULT_HANDLE,
            ),
            (
                "ResultManagementType_GetLatestResult",
                result::GET_LATEST_RESULT,
            ),
        ] {
            assert_eq!(csv_id(r, name), id, "{name}");
        }
    }

    #[test]
    fn every_nodeset_parses_and_names_its_namespace_first() {
        let imports = imports().unwrap();
        let own: Vec<String> = imports
            .iter()
            .map(|i| i.get_own_namespaces()[0].clone())
            .collect();
        assert_eq!(own, [DI, MACHINERY, RESULT, GONIO]);
        // Machinery lists DI as its second namespace: loaded after DI, it finds it.
        assert_eq!(imports[1].get_own_namespaces(), [MACHINERY, DI]);
    }
}
