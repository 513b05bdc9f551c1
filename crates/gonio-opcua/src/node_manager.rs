//! The node manager of the companion specifications' nodes and the machine's: the NodeSets
//! are loaded into its address space when the server is built, the machine's nodes added
//! beside them ([`crate::machine`]); it answers `ResultManagement`'s method calls
//! ([`crate::methods`]) and refuses every write.

use crate::Machine;
use crate::codec::Codec;
use crate::machine::{self, Ids};
use crate::methods::{self, Handles};
use crate::store::Stores;
use async_trait::async_trait;
use opcua::nodes::{DefaultTypeTree, NodeSetImport, NodeType};
use opcua::server::address_space::AddressSpace;
use opcua::server::diagnostics::NamespaceMetadata;
use opcua::server::node_manager::memory::{InMemoryNodeManager, InMemoryNodeManagerImpl};
use opcua::server::node_manager::{MethodCall, RequestContext, ServerContext, WriteNode};
use opcua::sync::RwLock;
use opcua::types::{
    BrowseDirection, DataTypeDefinition, NodeId, ReferenceTypeId, StatusCode, StructureDefinition,
};
use std::sync::{Arc, Mutex, OnceLock};

/// The node manager as the server holds it.
pub(crate) type GonioNodeManager = InMemoryNodeManager<GonioNodes>;

/// What the node manager, the method calls and the server's tasks share.
pub(crate) struct Shared {
    /// The namespaces' indices and the nodes' ids.
    pub(crate) ids: Ids,
    /// The machine described.
    pub(crate) machine: Machine,
    /// The results store.
    pub(crate) stores: Arc<Stores>,
    /// The result handles given out.
    pub(crate) handles: Mutex<Handles>,
    codec: OnceLock<Arc<Codec>>,
}

impl Shared {
    /// The structures' encodings (read from the address space the first time; the server's
    /// type tree is complete only once the server runs).
    pub(crate) fn codec(
        &self,
        types: &RwLock<DefaultTypeTree>,
        space: &RwLock<AddressSpace>,
    ) -> Result<Arc<Codec>, String> {
        if let Some(c) = self.codec.get() {
            return Ok(c.clone());
        }
        let c = Arc::new(Codec::new(&types.read(), &space.read(), &self.ids)?);
        Ok(self.codec.get_or_init(|| c).clone())
    }
}

/// The node manager's own part.
pub(crate) struct GonioNodes {
    namespaces: Vec<NamespaceMetadata>,
    /// `None` when the build failed (the reason is in the builder's slot).
    pub(crate) shared: Option<Arc<Shared>>,
}

/// Loads `imports` into `space` (registering their namespaces with the server), builds the
/// machine's nodes, and returns the node manager; an error is put in `failed`.
pub(crate) fn build(
    context: &ServerContext,
    space: &mut AddressSpace,
    imports: Vec<Box<dyn NodeSetImport>>,
    machine: Machine,
    stores: Arc<Stores>,
    failed: &Mutex<Option<String>>,
) -> GonioNodes {
    let mut namespaces: Vec<NamespaceMetadata> = Vec::new();
    {
        let mut types = context.type_tree.write();
        for import in &imports {
            space.import_node_set(&**import, types.namespaces_mut());
            for uri in import.get_own_namespaces() {
                if !namespaces.iter().any(|n| n.namespace_uri == uri) {
                    namespaces.push(NamespaceMetadata {
                        namespace_uri: uri,
                        ..Default::default()
                    });
                }
            }
        }
        for ns in &mut namespaces {
            ns.namespace_index = types.namespaces_mut().add_namespace(&ns.namespace_uri);
        }
    }
    for ns in &namespaces {
        space.add_namespace(&ns.namespace_uri, ns.namespace_index);
    }
    let shared = Ids::new(space).and_then(|ids| {
        {
            let types = context.type_tree.read();
            for id in ids.served_structures() {
                set_default_encoding(space, &types, &id)?;
            }
        }
        machine::build(space, &ids, &machine)?;
        Ok(Arc::new(Shared {
            ids,
            machine,
            stores,
            handles: Mutex::new(Handles::default()),
            codec: OnceLock::new(),
        }))
    });
    let shared = match shared {
        Ok(s) => Some(s),
        Err(e) => {
            if let Ok(mut f) = failed.lock() {
                *f = Some(e);
            }
            None
        }
    };
    GonioNodes { namespaces, shared }
}

/// Sets a structure's `DefaultEncodingId` (in its `DataTypeDefinition`) to its "Default
/// Binary" encoding node: the NodeSet importer leaves it null, and a client that reads the
/// definition to decode the structure needs it.
fn set_default_encoding(
    space: &mut AddressSpace,
    types: &DefaultTypeTree,
    id: &NodeId,
) -> Result<(), String> {
    let binary = space
        .find_references(
            id,
            Some((ReferenceTypeId::HasEncoding, false)),
            types,
            BrowseDirection::Forward,
        )
        .map(|r| r.target_node.clone())
        .find(|t| {
            space
                .find(t)
                .is_some_and(|n| n.as_node().browse_name().name.as_ref() == "Default Binary")
        })
        .ok_or_else(|| format!("DataType {id} has no Default Binary encoding"))?;
    let Some(NodeType::DataType(dt)) = space.find_mut(id) else {
        return Err(format!("no DataType node {id}"));
    };
    let def = match dt.data_type_definition() {
        Some(DataTypeDefinition::Structure(s)) => StructureDefinition {
            default_encoding_id: binary,
            ..s.clone()
        },
        _ => return Err(format!("DataType {id} is not a structure")),
    };
    dt.set_data_type_definition(Some(DataTypeDefinition::Structure(def)));
    Ok(())
}

#[async_trait]
impl InMemoryNodeManagerImpl for GonioNodes {
    async fn init(&self, _space: &mut AddressSpace, _context: ServerContext) {}

    fn name(&self) -> &str {
        "gonio"
    }

    fn namespaces(&self) -> Vec<NamespaceMetadata> {
        self.namespaces.clone()
    }

    async fn write(
        &self,
        _context: &RequestContext,
        _space: &RwLock<AddressSpace>,
        nodes_to_write: &mut [&mut WriteNode],
    ) -> Result<(), StatusCode> {
        for w in nodes_to_write {
            w.set_status(StatusCode::BadNotWritable);
        }
        Ok(())
    }

    async fn call(
        &self,
        context: &RequestContext,
        space: &RwLock<AddressSpace>,
        methods_to_call: &mut [&mut &mut MethodCall],
    ) -> Result<(), StatusCode> {
        let Some(shared) = &self.shared else {
            return Err(StatusCode::BadInternalError);
        };
        for call in methods_to_call {
            let Some(method) = shared.ids.which_method(call.method_id()) else {
                call.set_status(StatusCode::BadMethodInvalid);
                continue;
            };
            if call.object_id() != &shared.ids.result_management {
                call.set_status(StatusCode::BadMethodInvalid);
                continue;
            }
            let codec = match shared.codec(context.type_tree(), space) {
                Ok(c) => c,
                Err(_) => {
                    call.set_status(StatusCode::BadInternalError);
                    continue;
                }
            };
            match methods::call(shared, &codec, method, call.arguments()).await {
                Ok(outputs) => {
                    call.set_outputs(outputs);
                    call.set_status(StatusCode::Good);
                }
                Err(methods::CallError::Arguments(per_argument)) => {
                    call.set_argument_error(per_argument);
                }
                Err(methods::CallError::Status(s)) => call.set_status(s),
            }
        }
        Ok(())
    }
}
