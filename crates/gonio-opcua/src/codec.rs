//! The structures the server sends (`ResultDataType`, `ResultMetaDataType`,
//! `ProcessingTimesDataType` and gonio's `MountingResultDataType`), encoded from the
//! definitions the NodeSets give them: their fields, optional fields and binary encoding ids
//! are read from the loaded DataType nodes, so the encoding cannot drift from the model a
//! client reads. `async-opcua`'s `DynamicStructure` does the encoding.

use crate::machine::Ids;
use opcua::nodes::{DefaultTypeTree, NodeBase, NodeType, TypeTree};
use opcua::server::address_space::AddressSpace;
use opcua::types::custom::{
    DataTypeTree, DynamicStructure, EncodingIds, ParentIds, StructTypeInfo, TypeInfo,
};
use opcua::types::{DataTypeDefinition, DataTypeId, ExtensionObject, NodeId, Variant};
use std::sync::Arc;

/// The four structures' definitions.
pub(crate) struct Codec {
    tree: Arc<DataTypeTree>,
    /// `ResultDataType`.
    pub(crate) result: Arc<StructTypeInfo>,
    /// `ResultMetaDataType`.
    pub(crate) meta: Arc<StructTypeInfo>,
    /// `ProcessingTimesDataType`.
    pub(crate) times: Arc<StructTypeInfo>,
    /// gonio's `MountingResultDataType`.
    pub(crate) mounting: Arc<StructTypeInfo>,
}

impl Codec {
    /// Reads the definitions from the address space (`space`: the one the NodeSets were loaded
    /// into) and the server's type tree (every data type's supertype, down to the built-in
    /// type a field is encoded as).
    pub(crate) fn new(
        types: &DefaultTypeTree,
        space: &AddressSpace,
        ids: &Ids,
    ) -> Result<Codec, String> {
        let mut parents = ParentIds::new();
        let base: NodeId = DataTypeId::BaseDataType.into();
        for id in types.get_all_children(&base) {
            if let Some(p) = types.get_supertype(id) {
                parents.add_type(id.clone(), p.clone());
            }
        }
        let mut tree = DataTypeTree::new(parents);
        let served = ids.served_structures();
        let wanted: Vec<&NodeId> = served.iter().collect();
        for &id in &wanted {
            let info = type_info(space, id, tree.parent_ids())?;
            tree.add_type(id.clone(), info);
        }
        let get = |id: &NodeId| {
            tree.get_struct_type(id)
                .cloned()
                .ok_or_else(|| format!("{id} is not a structure"))
        };
        let (times, meta, result, mounting) = (
            get(wanted[0])?,
            get(wanted[1])?,
            get(wanted[2])?,
            get(wanted[3])?,
        );
        Ok(Codec {
            tree: Arc::new(tree),
            result,
            meta,
            times,
            mounting,
        })
    }

    /// A structure of type `ty` with the named fields set (every other field absent: only an
    /// optional field may be left out), as an extension object.
    pub(crate) fn make(
        &self,
        ty: &Arc<StructTypeInfo>,
        fields: Vec<(&str, Variant)>,
    ) -> Result<ExtensionObject, String> {
        let mut data = vec![Variant::Empty; ty.fields.len()];
        for (name, value) in fields {
            let Some(&i) = ty.index_by_name.get(name) else {
                return Err(format!("{} has no field {name}", ty.name));
            };
            data[i] = value;
        }
        DynamicStructure::new_struct(ty.clone(), self.tree.clone(), data)
            .map(ExtensionObject::new)
            .map_err(|e| format!("{}: {e}", ty.name))
    }
}

/// A structure's definition from its DataType node.
fn type_info(space: &AddressSpace, id: &NodeId, parents: &ParentIds) -> Result<TypeInfo, String> {
    let Some(NodeType::DataType(node)) = space.find(id) else {
        return Err(format!("no DataType node {id}"));
    };
    let Some(def) = node.data_type_definition() else {
        return Err(format!("DataType {id} has no definition"));
    };
    let DataTypeDefinition::Structure(s) = def else {
        return Err(format!("DataType {id} is not a structure"));
    };
    let encoding = EncodingIds {
        binary_id: s.default_encoding_id.clone(),
        json_id: NodeId::null(),
        xml_id: NodeId::null(),
    };
    TypeInfo::from_type_definition(
        def.clone(),
        node.browse_name().name.to_string(),
        Some(encoding),
        node.is_abstract(),
        id,
        parents,
    )
}
