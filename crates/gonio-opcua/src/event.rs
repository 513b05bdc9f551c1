//! The `ResultReadyEventType` event (OPC 40001-101) of a finished part: the base event's
//! fields (its source is the machine's `ResultManagement`, its time the part's end) and
//! `Result`, the part's `ResultDataType`; a client may also select a field inside it
//! (`Result/ResultMetaData/PartId`).

use opcua::nodes::{BaseEventType, Event};
use opcua::types::custom::DynamicStructure;
use opcua::types::{
    AttributeId, ByteString, DateTime, EventField, ExtensionObject, LocalizedText, NodeId,
    NumericRange, ObjectTypeId, QualifiedName, UAString, Variant,
};

/// Where the events come from: the event type, the `ResultManagement` object and its name.
#[derive(Debug, Clone)]
pub(crate) struct EventSource {
    /// `ResultReadyEventType`.
    pub(crate) event_type: NodeId,
    /// The Result Transfer namespace's index (the `Result` field's browse name).
    pub(crate) result_ns: u16,
    /// The machine's `ResultManagement` object.
    pub(crate) source: NodeId,
    /// Its name, for `SourceName`.
    pub(crate) source_name: String,
}

/// A `ResultReadyEventType` event.
#[derive(Debug)]
pub(crate) struct ResultReady {
    base: BaseEventType,
    /// The Result Transfer namespace's index (the `Result` field's browse name).
    result_ns: u16,
    /// The part's `ResultDataType`.
    result: ExtensionObject,
}

impl ResultReady {
    /// The event of one result (`time`: the part's end) with its message and severity (1 to
    /// 1000).
    pub(crate) fn new(
        from: &EventSource,
        time: DateTime,
        message: &str,
        severity: u16,
        result: ExtensionObject,
    ) -> ResultReady {
        let id = ByteString::from(opcua::types::Guid::new().to_bytes().to_vec());
        let base = BaseEventType::new(
            from.event_type.clone(),
            id,
            LocalizedText::new("en", message),
            time,
        )
        .set_source_node(from.source.clone())
        .set_source_name(UAString::from(from.source_name.as_str()))
        .set_receive_time(DateTime::now());
        ResultReady {
            base: BaseEventType { severity, ..base },
            result_ns: from.result_ns,
            result,
        }
    }

    /// A field of `Result` by its path below it (`[]`: the whole result).
    fn result_field(&self, path: &[QualifiedName]) -> Variant {
        let Some((first, rest)) = path.split_first() else {
            return Variant::from(self.result.clone());
        };
        let Some(result) = self.result.inner_as::<DynamicStructure>() else {
            return Variant::Empty;
        };
        let mut v = match result.get_field_by_name(first.name.as_ref()) {
            Some(v) if first.namespace_index == self.result_ns => v.clone(),
            _ => return Variant::Empty,
        };
        for q in rest {
            let Variant::ExtensionObject(o) = &v else {
                return Variant::Empty;
            };
            let next = o
                .inner_as::<DynamicStructure>()
                .and_then(|s| s.get_field_by_name(q.name.as_ref()))
                .cloned();
            match next {
                Some(n) if q.namespace_index == self.result_ns => v = n,
                _ => return Variant::Empty,
            }
        }
        v
    }
}

impl EventField for ResultReady {
    fn get_value(
        &self,
        attribute_id: AttributeId,
        index_range: &NumericRange,
        path: &[QualifiedName],
    ) -> Variant {
        match path.split_first() {
            Some((first, rest))
                if first.namespace_index == self.result_ns && first.name.as_ref() == "Result" =>
            {
                if attribute_id != AttributeId::Value {
                    return Variant::Empty;
                }
                self.result_field(rest)
                    .range_of_owned(index_range)
                    .unwrap_or(Variant::Empty)
            }
            _ => self.base.get_value(attribute_id, index_range, path),
        }
    }
}

impl Event for ResultReady {
    fn get_field(
        &self,
        type_definition_id: &NodeId,
        attribute_id: AttributeId,
        index_range: &NumericRange,
        browse_path: &[QualifiedName],
    ) -> Variant {
        // A select clause names the type that declares the field, or the base event type.
        if type_definition_id != &ObjectTypeId::BaseEventType
            && type_definition_id != self.base.event_type_id()
        {
            return Variant::Empty;
        }
        self.get_value(attribute_id, index_range, browse_path)
    }

    fn time(&self) -> &DateTime {
        &self.base.time
    }

    fn event_type_id(&self) -> &NodeId {
        &self.base.event_type
    }
}
