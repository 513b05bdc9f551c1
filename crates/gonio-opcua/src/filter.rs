//! `GetResultIdListFiltered`'s filter: an OPC UA `ContentFilter` over a result's metadata,
//! written here because `async-opcua` evaluates filters only over its events' fields.
//!
//! Operands: a literal, another element, or a `SimpleAttributeOperand` whose browse path names
//! a `ResultMetaData` field, with or without the `Result/ResultMetaData/` prefix (the paths of
//! `ResultReadyEventType`, `ResultType` and `ResultDataType`): `ResultId`, `PartId`,
//! `ProductId`, `InternalRecipeId`, `JobId`, `ResultState`, `ResultEvaluation`,
//! `IsSimulated`, `CreationTime`, `ResultEvaluationDetails`. Operators: `Equals`,
//! `GreaterThan`, `LessThan`, `GreaterThanOrEqual`, `LessThanOrEqual`, `Between`, `InList`,
//! `IsNull`, `Like` (`%` any characters, `_` one), `And`, `Or`, `Not`. Numbers compare as
//! numbers whatever their type, times as times, texts as texts; a comparison of values of
//! different kinds, or with a field the result does not have, is false. Anything else is
//! refused when the filter is read, with what is not supported.

use opcua::types::{
    ContentFilter, ContentFilterElement, ElementOperand, ExtensionObject, FilterOperator,
    LiteralOperand, SimpleAttributeOperand, Variant,
};
use std::cmp::Ordering;

/// The metadata fields a filter may name.
const FIELDS: [&str; 10] = [
    "ResultId",
    "PartId",
    "ProductId",
    "InternalRecipeId",
    "JobId",
    "ResultState",
    "ResultEvaluation",
    "IsSimulated",
    "CreationTime",
    "ResultEvaluationDetails",
];

/// An operand, resolved.
#[derive(Debug, Clone, PartialEq)]
enum Operand {
    /// A literal value.
    Literal(Variant),
    /// A metadata field.
    Field(&'static str),
    /// Another element's result.
    Element(usize),
}

/// A filter ready to be evaluated.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Filter {
    elements: Vec<(FilterOperator, Vec<Operand>)>,
}

/// A value as the filter compares it.
#[derive(Debug, Clone, PartialEq)]
enum Value {
    Number(f64),
    Text(String),
    Bool(bool),
    Time(i64),
}

fn value(v: &Variant) -> Option<Value> {
    Some(match v {
        Variant::Boolean(b) => Value::Bool(*b),
        Variant::SByte(x) => Value::Number(f64::from(*x)),
        Variant::Byte(x) => Value::Number(f64::from(*x)),
        Variant::Int16(x) => Value::Number(f64::from(*x)),
        Variant::UInt16(x) => Value::Number(f64::from(*x)),
        Variant::Int32(x) => Value::Number(f64::from(*x)),
        Variant::UInt32(x) => Value::Number(f64::from(*x)),
        Variant::Int64(x) => Value::Number(*x as f64),
        Variant::UInt64(x) => Value::Number(*x as f64),
        Variant::Float(x) => Value::Number(f64::from(*x)),
        Variant::Double(x) => Value::Number(*x),
        Variant::String(s) => Value::Text(s.as_ref().to_string()),
        Variant::LocalizedText(t) => Value::Text(t.text.as_ref().to_string()),
        Variant::DateTime(t) => Value::Time(t.checked_ticks()),
        _ => return None,
    })
}

fn compare(a: &Value, b: &Value) -> Option<Ordering> {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => x.partial_cmp(y),
        (Value::Text(x), Value::Text(y)) => Some(x.cmp(y)),
        (Value::Bool(x), Value::Bool(y)) => Some(x.cmp(y)),
        (Value::Time(x), Value::Time(y)) => Some(x.cmp(y)),
        _ => None,
    }
}

/// SQL-like `Like`: `%` any run of characters, `_` one character.
fn like(text: &str, pattern: &str) -> bool {
    let (t, p): (Vec<char>, Vec<char>) = (text.chars().collect(), pattern.chars().collect());
    // best[j]: the pattern's first j characters match some prefix seen so far.
    let mut m = vec![vec![false; p.len() + 1]; t.len() + 1];
    m[0][0] = true;
    for j in 1..=p.len() {
        m[0][j] = m[0][j - 1] && p[j - 1] == '%';
    }
    for i in 1..=t.len() {
        for j in 1..=p.len() {
            m[i][j] = match p[j - 1] {
                '%' => m[i][j - 1] || m[i - 1][j],
                '_' => m[i - 1][j - 1],
                c => m[i - 1][j - 1] && t[i - 1] == c,
            };
        }
    }
    m[t.len()][p.len()]
}

impl Filter {
    /// Reads the `Filter` argument (a `ContentFilter`; null or without elements: every
    /// result). `result_ns` is the Result Transfer namespace's index (browse names in any
    /// other namespace name no field).
    pub(crate) fn parse(arg: &Variant, result_ns: u16) -> Result<Filter, String> {
        let cf = match arg {
            Variant::Empty => return Ok(Filter { elements: vec![] }),
            Variant::ExtensionObject(o) if o.is_null() => {
                return Ok(Filter { elements: vec![] });
            }
            Variant::ExtensionObject(o) => o
                .inner_as::<ContentFilter>()
                .ok_or("the Filter argument is not a ContentFilter")?,
            _ => return Err("the Filter argument is not a ContentFilter".into()),
        };
        let elements = cf.elements.as_deref().unwrap_or_default();
        let mut out = Vec::with_capacity(elements.len());
        for (i, e) in elements.iter().enumerate() {
            out.push(Self::element(i, e, elements.len(), result_ns)?);
        }
        Ok(Filter { elements: out })
    }

    fn element(
        i: usize,
        e: &ContentFilterElement,
        count: usize,
        result_ns: u16,
    ) -> Result<(FilterOperator, Vec<Operand>), String> {
        use FilterOperator as F;
        let arity: &[usize] = match e.filter_operator {
            F::IsNull | F::Not => &[1],
            F::Equals
            | F::GreaterThan
            | F::LessThan
            | F::GreaterThanOrEqual
            | F::LessThanOrEqual
            | F::Like
            | F::And
            | F::Or => &[2],
            F::Between => &[3],
            F::InList => &[],
            other => return Err(format!("element {i}: operator {other:?} is not supported")),
        };
        let operands: Vec<Operand> = e
            .filter_operands
            .as_deref()
            .unwrap_or_default()
            .iter()
            .map(|o| Self::operand(i, o, count, result_ns))
            .collect::<Result<_, _>>()?;
        let ok = if arity.is_empty() {
            operands.len() >= 2
        } else {
            arity.contains(&operands.len())
        };
        if !ok {
            return Err(format!(
                "element {i}: {:?} takes {} operands, {} given",
                e.filter_operator,
                if arity.is_empty() {
                    "2 or more".to_string()
                } else {
                    arity[0].to_string()
                },
                operands.len()
            ));
        }
        Ok((e.filter_operator, operands))
    }

    fn operand(
        i: usize,
        o: &ExtensionObject,
        count: usize,
        result_ns: u16,
    ) -> Result<Operand, String> {
        if let Some(l) = o.inner_as::<LiteralOperand>() {
            return Ok(Operand::Literal(l.value.clone()));
        }
        if let Some(e) = o.inner_as::<ElementOperand>() {
            let j = e.index as usize;
            // Only later elements: a filter is a tree, never a loop.
            if j <= i || j >= count {
                return Err(format!(
                    "element {i}: element operand {j} is not a later element"
                ));
            }
            return Ok(Operand::Element(j));
        }
        if let Some(a) = o.inner_as::<SimpleAttributeOperand>() {
            let path = a.browse_path.as_deref().unwrap_or_default();
            let mut names: Vec<&str> = Vec::with_capacity(path.len());
            for q in path {
                if q.namespace_index != result_ns {
                    return Err(format!(
                        "element {i}: browse name {}:{} is not in the Result namespace ({result_ns})",
                        q.namespace_index, q.name
                    ));
                }
                names.push(q.name.as_ref());
            }
            let field = match names.as_slice() {
                ["Result", "ResultMetaData", f] | ["ResultMetaData", f] | [f] => *f,
                _ => {
                    return Err(format!(
                        "element {i}: browse path {} names no ResultMetaData field",
                        names.join("/")
                    ));
                }
            };
            return FIELDS
                .iter()
                .find(|n| **n == field)
                .map(|n| Operand::Field(n))
                .ok_or_else(|| format!("element {i}: {field} is not a field a filter can use"));
        }
        Err(format!(
            "element {i}: operand {} is not supported",
            o.type_name().unwrap_or("(null)")
        ))
    }

    /// Whether a result with these metadata `fields` passes (no elements: every result does).
    pub(crate) fn matches(&self, fields: &[(&'static str, Variant)]) -> bool {
        self.elements.is_empty() || self.eval(0, fields)
    }

    fn get(&self, o: &Operand, fields: &[(&'static str, Variant)]) -> Option<Value> {
        match o {
            Operand::Literal(v) => value(v),
            Operand::Field(f) => fields.iter().find(|x| x.0 == *f).and_then(|x| value(&x.1)),
            Operand::Element(j) => Some(Value::Bool(self.eval(*j, fields))),
        }
    }

    fn eval(&self, i: usize, fields: &[(&'static str, Variant)]) -> bool {
        use FilterOperator as F;
        let (op, ops) = &self.elements[i];
        let v = |k: usize| self.get(&ops[k], fields);
        let cmp = |a: usize, b: usize| v(a).zip(v(b)).and_then(|(x, y)| compare(&x, &y));
        let truth = |k: usize| v(k) == Some(Value::Bool(true));
        match op {
            F::Equals => cmp(0, 1) == Some(Ordering::Equal),
            F::GreaterThan => cmp(0, 1) == Some(Ordering::Greater),
            F::LessThan => cmp(0, 1) == Some(Ordering::Less),
            F::GreaterThanOrEqual => matches!(cmp(0, 1), Some(Ordering::Greater | Ordering::Equal)),
            F::LessThanOrEqual => matches!(cmp(0, 1), Some(Ordering::Less | Ordering::Equal)),
            F::Between => {
                matches!(cmp(0, 1), Some(Ordering::Greater | Ordering::Equal))
                    && matches!(cmp(0, 2), Some(Ordering::Less | Ordering::Equal))
            }
            F::InList => (1..ops.len()).any(|k| cmp(0, k) == Some(Ordering::Equal)),
            F::IsNull => v(0).is_none(),
            F::Like => match (v(0), v(1)) {
                (Some(Value::Text(t)), Some(Value::Text(p))) => like(&t, &p),
                _ => false,
            },
            F::And => truth(0) && truth(1),
            F::Or => truth(0) || truth(1),
            F::Not => !truth(0),
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use opcua::types::QualifiedName;

    const NS: u16 = 4;

    fn field(path: &[&str]) -> ExtensionObject {
        ExtensionObject::from_message(SimpleAttributeOperand {
            type_definition_id: Default::default(),
            browse_path: Some(path.iter().map(|p| QualifiedName::new(NS, *p)).collect()),
            attribute_id: 13,
            index_range: Default::default(),
        })
    }

    fn lit(v: impl Into<Variant>) -> ExtensionObject {
        ExtensionObject::from_message(LiteralOperand { value: v.into() })
    }

    fn el(i: u32) -> ExtensionObject {
        ExtensionObject::from_message(ElementOperand { index: i })
    }

    fn filter(elements: Vec<(FilterOperator, Vec<ExtensionObject>)>) -> Result<Filter, String> {
        let cf = ContentFilter {
            elements: Some(
                elements
                    .into_iter()
                    .map(|(filter_operator, ops)| ContentFilterElement {
                        filter_operator,
                        filter_operands: Some(ops),
                    })
                    .collect(),
            ),
        };
        Filter::parse(&Variant::from(ExtensionObject::from_message(cf)), NS)
    }

    fn meta(part: &str, evaluation: i32) -> Vec<(&'static str, Variant)> {
        vec![
            ("PartId", Variant::from(part)),
            ("ResultEvaluation", Variant::Int32(evaluation)),
            ("IsSimulated", Variant::Boolean(true)),
        ]
    }

    #[test]
    fn an_empty_filter_passes_everything() {
        let f = Filter::parse(&Variant::Empty, NS).unwrap();
        assert!(f.matches(&meta("A", 2)));
    }

    #[test]
    fn comparisons_and_logic_over_the_metadata() {
        use FilterOperator as F;
        // PartId = "A-2" and not ResultEvaluation = 1 (OK)
        let f = filter(vec![
            (F::And, vec![el(1), el(2)]),
            (
                F::Equals,
                vec![field(&["Result", "ResultMetaData", "PartId"]), lit("A-2")],
            ),
            (F::Not, vec![el(3)]),
            (F::Equals, vec![field(&["ResultEvaluation"]), lit(1i32)]),
        ])
        .unwrap();
        assert!(f.matches(&meta("A-2", 2)));
        assert!(!f.matches(&meta("A-2", 1)));
        assert!(!f.matches(&meta("A-3", 2)));
        // Numbers compare across types; a missing field compares false.
        let f = filter(vec![(
            F::GreaterThanOrEqual,
            vec![field(&["ResultMetaData", "ResultEvaluation"]), lit(2.0f64)],
        )])
        .unwrap();
        assert!(f.matches(&meta("x", 2)) && !f.matches(&meta("x", 1)));
        let f = filter(vec![(F::Equals, vec![field(&["ProductId"]), lit("r")])]).unwrap();
        assert!(!f.matches(&meta("x", 2)));
        let f = filter(vec![(F::Like, vec![field(&["PartId"]), lit("A-%")])]).unwrap();
        assert!(f.matches(&meta("A-17", 1)) && !f.matches(&meta("B-1", 1)));
        let f = filter(vec![(
            F::InList,
            vec![field(&["PartId"]), lit("a"), lit("b")],
        )])
        .unwrap();
        assert!(f.matches(&meta("b", 1)) && !f.matches(&meta("c", 1)));
    }

    #[test]
    fn what_is_not_supported_is_refused_by_name() {
        use FilterOperator as F;
        let e = filter(vec![(F::OfType, vec![lit(1i32)])]).unwrap_err();
        assert!(e.contains("OfType"), "{e}");
        let e = filter(vec![(F::Equals, vec![field(&["Speed"]), lit(1i32)])]).unwrap_err();
        assert!(e.contains("Speed"), "{e}");
        let e = filter(vec![(F::Not, vec![el(0)])]).unwrap_err();
        assert!(e.contains("later element"), "{e}");
        let e = filter(vec![(F::Equals, vec![lit(1i32)])]).unwrap_err();
        assert!(e.contains("takes 2 operands"), "{e}");
    }

    #[test]
    fn like_matches_sql_patterns() {
        assert!(like("abc", "a%"));
        assert!(like("abc", "%c"));
        assert!(like("abc", "a_c"));
        assert!(!like("abc", "a_"));
        assert!(like("", "%"));
        assert!(!like("abc", "b%"));
    }
}
