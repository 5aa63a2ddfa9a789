//! The vehicle's buses: DBC files bound to a bus (an interface name, `can1=powertrain.dbc`) or to
//! every bus (an unbound file), so the same id on two buses is two messages. A clash, the same id
//! twice where the buses overlap, is refused naming every clashing id at once.
use can_codec::{CanId, Database, MessageSpec};

/// One DBC file of the vehicle and the bus it describes.
#[derive(Clone, Debug)]
pub struct BusPart {
    /// The interface the file's messages travel on; `None`: every bus.
    pub bus: Option<String>,
    /// Where the file came from, for messages (a path or `builtin:riskscore`).
    pub origin: String,
    pub db: Database,
}

/// Every DBC file of the vehicle, each bound to a bus or to all of them.
#[derive(Clone, Debug, Default)]
pub struct BusDatabase {
    pub parts: Vec<BusPart>,
}

/// One id defined twice on a bus.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Clash {
    pub id: CanId,
    pub first: String,
    pub first_origin: String,
    pub second: String,
    pub second_origin: String,
}

impl std::fmt::Display for Clash {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "0x{}: `{}` in {} and `{}` in {}",
            self.id, self.first, self.first_origin, self.second, self.second_origin
        )
    }
}

/// `bus` as written in messages: the interface, or "all buses".
pub fn bus_label(bus: Option<&str>) -> String {
    bus.map_or("all buses".into(), |b| format!("bus {b}"))
}

impl BusDatabase {
    /// One database on every bus (the single-bus case).
    pub fn unbound(db: Database, origin: &str) -> Self {
        Self {
            parts: vec![BusPart {
                bus: None,
                origin: origin.into(),
                db,
            }],
        }
    }

    /// Adds a file; every id it shares with a file on an overlapping bus (the same bus, or
    /// either unbound) is returned, and nothing is added then.
    pub fn add(&mut self, part: BusPart) -> Result<(), Vec<Clash>> {
        let mut clashes = Vec::new();
        for other in &self.parts {
            let overlap = match (&other.bus, &part.bus) {
                (Some(a), Some(b)) => a == b,
                _ => true,
            };
            if !overlap {
                continue;
            }
            for m in &part.db.messages {
                if let Some(o) = other.db.message_by_id(m.id) {
                    clashes.push(Clash {
                        id: m.id,
                        first: o.name.clone(),
                        first_origin: other.origin.clone(),
                        second: m.name.clone(),
                        second_origin: part.origin.clone(),
                    });
                }
            }
        }
        if !clashes.is_empty() {
            return Err(clashes);
        }
        self.parts.push(part);
        Ok(())
    }

    /// Every message with the bus it is on (`None`: every bus).
    pub fn messages(&self) -> impl Iterator<Item = (Option<&str>, &MessageSpec)> {
        self.parts
            .iter()
            .flat_map(|p| p.db.messages.iter().map(move |m| (p.bus.as_deref(), m)))
    }

    /// The buses named by bound files, in order of first appearance.
    pub fn bus_names(&self) -> Vec<String> {
        let mut names: Vec<String> = Vec::new();
        for b in self.parts.iter().filter_map(|p| p.bus.as_ref()) {
            if !names.contains(b) {
                names.push(b.clone());
            }
        }
        names
    }

    /// The files, as `bus=file` or `file`, for messages.
    pub fn describe(&self) -> String {
        self.parts
            .iter()
            .map(|p| match &p.bus {
                Some(b) => format!("{b}={}", p.origin),
                None => p.origin.clone(),
            })
            .collect::<Vec<_>>()
            .join(" + ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn db(ids: &[(u32, &str)]) -> Database {
        let mut text = String::from("VERSION \"\"\n\nBU_: X\n\n");
        for (id, name) in ids {
            text.push_str(&format!(
                "BO_ {id} {name}: 1 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n\n"
            ));
        }
        Database::parse(&text).unwrap()
    }

    fn part(bus: Option<&str>, origin: &str, d: Database) -> BusPart {
        BusPart {
            bus: bus.map(Into::into),
            origin: origin.into(),
            db: d,
        }
    }

    #[test]
    fn same_id_on_two_buses_is_two_messages_and_every_clash_is_named() {
        let mut all = BusDatabase::default();
        all.add(part(
            Some("can0"),
            "radar.dbc",
            db(&[(0x224, "A"), (0x228, "B")]),
        ))
        .unwrap();
        all.add(part(
            Some("can1"),
            "pt.dbc",
            db(&[(0x224, "C"), (0x228, "D")]),
        ))
        .unwrap();
        assert_eq!(all.messages().count(), 4);
        assert_eq!(all.bus_names(), ["can0", "can1"]);
        // An unbound file is on every bus: it clashes with both, and every id is named.
        let err = all
            .add(part(
                None,
                "x.dbc",
                db(&[(0x224, "E"), (0x228, "F"), (0x300, "G")]),
            ))
            .unwrap_err();
        let ids: Vec<_> = err.iter().map(|c| (c.id.raw(), c.first.as_str())).collect();
        assert_eq!(
            ids,
            [(0x224, "A"), (0x228, "B"), (0x224, "C"), (0x228, "D")]
        );
        assert_eq!(all.parts.len(), 2, "nothing of a refused file is added");
        let same_bus = all
            .add(part(Some("can1"), "y.dbc", db(&[(0x228, "H")])))
            .unwrap_err();
        assert_eq!(same_bus.len(), 1);
        assert_eq!(
            same_bus[0].to_string(),
            "0x228: `D` in pt.dbc and `H` in y.dbc"
        );
    }
}
