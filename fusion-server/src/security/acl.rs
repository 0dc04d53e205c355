//! The Zenoh access-control list generated from the roster (pure: ids in, configuration out).
//!
//! Default deny. A node whose certificate names no roster member may do nothing: its
//! publications, declarations and queries are dropped where it connects, and nothing is
//! sent to it. Robot `{id}` (common name `robot:{id}`) may
//! - publish and hold its liveliness token under `{prefix}/robots/{id}/**`, nowhere else;
//! - subscribe to and query `{prefix}/ball/**`, and receive the ball and the answers;
//! - learn of the servers' subscribers, queryables and tokens (how its publications find
//!   them).
//!
//! Servers and routers may do anything under `{prefix}/**`.

use crate::security::{robot_common_name, router_common_name, server_common_name};
use serde_json::{Value, json};

/// Who the list admits.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Roster<'a> {
    pub prefix: &'a str,
    pub robots: &'a [String],
    pub servers: &'a [String],
    pub routers: &'a [String],
}

/// Every message kind Zenoh's access control knows.
const ALL_MESSAGES: [&str; 9] = [
    "put",
    "delete",
    "declare_subscriber",
    "query",
    "declare_queryable",
    "reply",
    "liveliness_token",
    "declare_liveliness_subscriber",
    "liveliness_query",
];

/// The `access_control` section of a Zenoh configuration for `roster`.
pub fn access_control(roster: &Roster<'_>) -> Value {
    let p = roster.prefix;
    let mut rules = vec![
        json!({
            "id": "robots-read-ball",
            "messages": ["declare_subscriber", "query"],
            "flows": ["ingress"],
            "key_exprs": [format!("{p}/ball/**")],
            "permission": "allow",
        }),
        json!({
            "id": "ball-to-robots",
            "messages": ["put", "reply"],
            "flows": ["egress"],
            "key_exprs": [format!("{p}/ball/**")],
            "permission": "allow",
        }),
        // The servers' subscribers, queryables and tokens: a robot's publisher only sends
        // where it knows a subscriber.
        json!({
            "id": "declarations-to-robots",
            "messages": [
                "declare_subscriber",
                "declare_queryable",
                "liveliness_token",
                "declare_liveliness_subscriber",
            ],
            "flows": ["egress"],
            "key_exprs": [format!("{p}/**")],
            "permission": "allow",
        }),
        json!({
            "id": "trusted-all",
            "messages": ALL_MESSAGES,
            "flows": ["ingress", "egress"],
            "key_exprs": [format!("{p}/**")],
            "permission": "allow",
        }),
    ];
    let mut subjects = Vec::new();
    let mut policies = Vec::new();
    for id in roster.robots {
        let (rule, subject) = (format!("robot-{id}-own-keys"), format!("robot-{id}"));
        rules.push(json!({
            "id": rule,
            "messages": ["put", "delete", "liveliness_token"],
            "flows": ["ingress"],
            "key_exprs": [format!("{p}/robots/{id}/**")],
            "permission": "allow",
        }));
        subjects.push(json!({ "id": subject, "cert_common_names": [robot_common_name(id)] }));
        policies.push(json!({
            "rules": [rule, "robots-read-ball", "ball-to-robots", "declarations-to-robots"],
            "subjects": [subject],
        }));
    }
    let trusted: Vec<String> = roster
        .servers
        .iter()
        .map(|s| server_common_name(s))
        .chain(roster.routers.iter().map(|r| router_common_name(r)))
        .collect();
    if !trusted.is_empty() {
        subjects.push(json!({ "id": "trusted", "cert_common_names": trusted }));
        policies.push(json!({ "rules": ["trusted-all"], "subjects": ["trusted"] }));
    }
    json!({
        "enabled": true,
        "default_permission": "deny",
        "rules": rules,
        "subjects": subjects,
        "policies": policies,
    })
}

/// Puts `roster`'s access-control list into a Zenoh configuration.
pub fn install(config: &mut zenoh::Config, roster: &Roster<'_>) -> Result<(), String> {
    config
        .insert_json5("access_control", &access_control(roster).to_string())
        .map_err(|e| format!("access control: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ids(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn each_robot_publishes_only_under_its_own_id() {
        let (robots, servers) = (ids(&["miro1", "miro2"]), ids(&["main"]));
        let acl = access_control(&Roster {
            prefix: "lab/pitch",
            robots: &robots,
            servers: &servers,
            routers: &[],
        });
        assert_eq!(acl["default_permission"], "deny");
        let rule = |id: &str| {
            acl["rules"]
                .as_array()
                .and_then(|r| r.iter().find(|r| r["id"] == id))
                .cloned()
                .unwrap_or_default()
        };
        assert_eq!(
            rule("robot-miro2-own-keys")["key_exprs"],
            json!(["lab/pitch/robots/miro2/**"])
        );
        assert_eq!(rule("robot-miro2-own-keys")["flows"], json!(["ingress"]));
        // Nobody but the trusted may put on the ball.
        for r in acl["rules"].as_array().into_iter().flatten() {
            let puts = r["messages"]
                .as_array()
                .is_some_and(|m| m.contains(&json!("put")));
            let ingress = r["flows"]
                .as_array()
                .is_some_and(|f| f.contains(&json!("ingress")));
            if puts && ingress && r["id"] != "trusted-all" {
                assert!(
                    r["key_exprs"][0]
                        .as_str()
                        .is_some_and(|k| k.contains("/robots/"))
                );
            }
        }
        let policy_of = |subject: &str| {
            acl["policies"]
                .as_array()
                .and_then(|p| p.iter().find(|p| p["subjects"][0] == subject))
                .cloned()
                .unwrap_or_default()
        };
        assert_eq!(policy_of("robot-miro1")["rules"][0], "robot-miro1-own-keys");
        assert_eq!(policy_of("trusted")["rules"], json!(["trusted-all"]));
    }

    #[test]
    fn zenoh_accepts_the_list() -> Result<(), String> {
        let (robots, servers, routers) = (ids(&["miro1"]), ids(&["a", "b"]), ids(&["r1"]));
        let mut c = zenoh::Config::default();
        install(
            &mut c,
            &Roster {
                prefix: "rf",
                robots: &robots,
                servers: &servers,
                routers: &routers,
            },
        )?;
        let subjects = c.get_json("access_control/subjects").unwrap_or_default();
        assert!(subjects.contains("server:b") && subjects.contains("router:r1"));
        assert!(subjects.contains("robot:miro1"));
        Ok(())
    }
}
