//! Stable ids of a world's items: bodies, joints, couplings, force elements and colliders. An id is
//! the item's index in creation order in its [`World`](super::World) and stays valid for the world's
//! life (nothing is removed). Every other file of the dynamics names items through these.

/// An id type: a `u32` index in creation order, with its `index()` into the world's list.
macro_rules! item_id {
    ($(#[$doc:meta])* $name:ident, $list:literal) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
        pub struct $name(pub u32);

        impl $name {
            #[doc = concat!("Index in the world's ", $list, " list.")]
            #[inline]
            pub fn index(self) -> usize {
                self.0 as usize
            }
        }
    };
}

item_id!(
    /// Stable id of a body in its [`World`](super::World) (index in creation order).
    BodyId,
    "body"
);
item_id!(
    /// Stable id of a joint in its [`World`](super::World) (index in creation order).
    JointId,
    "joint"
);
item_id!(
    /// Stable id of a coupling in its [`World`](super::World) (index in creation order).
    CouplingId,
    "coupling"
);
item_id!(
    /// Stable id of a force element in its [`World`](super::World) (index in creation order).
    ForceId,
    "force"
);
item_id!(
    /// Stable id of a collider in its [`World`](super::World) (index in creation order).
    ColliderId,
    "collider"
);
