// Joints to session space, engine-neutral: the library gives every OpenXR joint in the wrist
// joint's frame (the glove senses the fingers, not where the hand is); the engine's tracker gives
// the wrist's pose in session space. A joint's session pose is wrist * joint: rotate the joint's
// position by the wrist's orientation, add the wrist's position, and multiply the orientations
// wrist first. (In Unity terms jointPose.GetTransformedBy(wristPose), not the other way round.)
//
// OpenXR and Godot are right-handed (+Y up, -Z forward); Unity is left-handed (+Z forward). The
// To/FromLeftHanded functions mirror Z, as Unity's OpenXR plugin does; mirroring commutes with
// composition, so compose in either frame as long as both poses are in the same one.
namespace GlovePose
{
    public static class HandSpace
    {
        /// <summary>a * b: the rotation b, then a.</summary>
        public static Quaternionf Multiply(Quaternionf a, Quaternionf b)
        {
            return new Quaternionf(
                a.W * b.X + a.X * b.W + a.Y * b.Z - a.Z * b.Y,
                a.W * b.Y - a.X * b.Z + a.Y * b.W + a.Z * b.X,
                a.W * b.Z + a.X * b.Y - a.Y * b.X + a.Z * b.W,
                a.W * b.W - a.X * b.X - a.Y * b.Y - a.Z * b.Z);
        }

        /// <summary>v rotated by the unit quaternion q.</summary>
        public static Vector3f Rotate(Quaternionf q, Vector3f v)
        {
            // t = 2 q.xyz x v; v' = v + w t + q.xyz x t
            float tx = 2f * (q.Y * v.Z - q.Z * v.Y);
            float ty = 2f * (q.Z * v.X - q.X * v.Z);
            float tz = 2f * (q.X * v.Y - q.Y * v.X);
            return new Vector3f(
                v.X + q.W * tx + (q.Y * tz - q.Z * ty),
                v.Y + q.W * ty + (q.Z * tx - q.X * tz),
                v.Z + q.W * tz + (q.X * ty - q.Y * tx));
        }

        /// <summary>parent * child: a pose given in parent's frame, expressed where parent is given.</summary>
        public static Posef Compose(Posef parent, Posef child)
        {
            Vector3f p = Rotate(parent.Orientation, child.Position);
            return new Posef(Multiply(parent.Orientation, child.Orientation),
                             new Vector3f(parent.Position.X + p.X, parent.Position.Y + p.Y, parent.Position.Z + p.Z));
        }

        /// <summary>A joint (or the aim pose) given in the wrist joint's frame, in session space,
        /// for the wrist's session pose from the engine's tracker.</summary>
        public static Posef ToSession(Posef wristInSession, Posef jointInWrist) { return Compose(wristInSession, jointInWrist); }

        /// <summary>A joint's velocity in session space: the wrist's own motion (its linear and
        /// angular velocity from the tracker, zero if unknown) plus the joint's velocity in the
        /// wrist's frame, rotated: v = v_wrist + w_wrist x (R p) + R v_joint, w = w_wrist + R w_joint.
        /// Check the joint's XrVelocityFlags before using either.</summary>
        public static void VelocityToSession(Posef wristInSession, Vector3f wristLinear, Vector3f wristAngular,
                                             Vector3f jointPositionInWrist, XrJointVelocity jointVelocity,
                                             out Vector3f linear, out Vector3f angular)
        {
            Vector3f r = Rotate(wristInSession.Orientation, jointPositionInWrist);
            Vector3f v = Rotate(wristInSession.Orientation, jointVelocity.LinearVelocity);
            Vector3f w = Rotate(wristInSession.Orientation, jointVelocity.AngularVelocity);
            linear = new Vector3f(wristLinear.X + (wristAngular.Y * r.Z - wristAngular.Z * r.Y) + v.X,
                                  wristLinear.Y + (wristAngular.Z * r.X - wristAngular.X * r.Z) + v.Y,
                                  wristLinear.Z + (wristAngular.X * r.Y - wristAngular.Y * r.X) + v.Z);
            angular = new Vector3f(wristAngular.X + w.X, wristAngular.Y + w.Y, wristAngular.Z + w.Z);
        }

        /// <summary>A right-handed (OpenXR, Godot) position or linear velocity in Unity's left-handed
        /// frame, and back (the same mirror): z negated.</summary>
        public static Vector3f MirrorZ(Vector3f v) { return new Vector3f(v.X, v.Y, -v.Z); }

        /// <summary>An angular velocity (axis times rate) across the Z mirror: a mirror reverses the
        /// sense of rotation, so x and y are negated, z kept.</summary>
        public static Vector3f MirrorZAngular(Vector3f w) { return new Vector3f(-w.X, -w.Y, w.Z); }

        /// <summary>An orientation across the Z mirror: x and y negated, z and w kept.</summary>
        public static Quaternionf MirrorZ(Quaternionf q) { return new Quaternionf(-q.X, -q.Y, q.Z, q.W); }

        /// <summary>A pose across the Z mirror (OpenXR to Unity, or Unity to OpenXR).</summary>
        public static Posef MirrorZ(Posef pose) { return new Posef(MirrorZ(pose.Orientation), MirrorZ(pose.Position)); }
    }
}
