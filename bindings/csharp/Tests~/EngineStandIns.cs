// Stand-ins for the few Unity and Godot types the engine code in capi/README.md uses, with the
// engines' names, signatures and enum values (XR Hands 1.x, Godot 4.3 .NET), so that this code is
// compiled and run by capi_csharp. They only hold what they are given: every computation the
// README's code does is its own or the package's. Not a substitute for compiling in the engines.
using System;
using System.Collections.Generic;

namespace UnityEngine
{
    public struct Vector3
    {
        public float x, y, z;
        public Vector3(float x, float y, float z) { this.x = x; this.y = y; this.z = z; }
    }

    public struct Quaternion
    {
        public float x, y, z, w;
        public Quaternion(float x, float y, float z, float w) { this.x = x; this.y = y; this.z = z; this.w = w; }
    }

    public struct Pose
    {
        public Vector3 position;
        public Quaternion rotation;
        public Pose(Vector3 position, Quaternion rotation) { this.position = position; this.rotation = rotation; }
    }
}

namespace Unity.Collections
{
    public struct NativeArray<T> where T : struct
    {
        readonly T[] items;
        public NativeArray(int length) { items = new T[length]; }
        public int Length { get { return items.Length; } }
        public T this[int index] { get { return items[index]; } set { items[index] = value; } }
    }
}

namespace UnityEngine.XR.Hands
{
    public enum Handedness { Invalid = 0, Left = 1, Right = 2 }

    [Flags]
    public enum XRHandJointTrackingState { None = 0, Radius = 1, Pose = 2, LinearVelocity = 4, AngularVelocity = 8, WillNeverBeValid = 16, HighFidelityPose = 32 }

    public enum XRHandJointID
    {
        Invalid = 0, Wrist = 1, Palm = 2,
        ThumbMetacarpal = 3, ThumbProximal = 4, ThumbDistal = 5, ThumbTip = 6,
        IndexMetacarpal = 7, IndexProximal = 8, IndexIntermediate = 9, IndexDistal = 10, IndexTip = 11,
        MiddleMetacarpal = 12, MiddleProximal = 13, MiddleIntermediate = 14, MiddleDistal = 15, MiddleTip = 16,
        RingMetacarpal = 17, RingProximal = 18, RingIntermediate = 19, RingDistal = 20, RingTip = 21,
        LittleMetacarpal = 22, LittleProximal = 23, LittleIntermediate = 24, LittleDistal = 25, LittleTip = 26,
    }

    public static class XRHandJointIDUtility
    {
        public static XRHandJointID FromIndex(int index) { return (XRHandJointID)(index + 1); }
        public static int ToIndex(XRHandJointID id) { return (int)id - 1; }
    }

    public struct XRHandJoint
    {
        public Handedness handedness;
        public XRHandJointTrackingState trackingState;
        public XRHandJointID id;
        public Pose pose;
        public float radius;
        public Vector3 linearVelocity, angularVelocity;
    }
}

namespace UnityEngine.XR.Hands.ProviderImplementation
{
    public static class XRHandProviderUtility
    {
        public static XRHandJoint CreateJoint(Handedness handedness, XRHandJointTrackingState trackingState, XRHandJointID id, Pose pose,
                                              float radius = 0f, Vector3 linearVelocity = default(Vector3), Vector3 angularVelocity = default(Vector3))
        {
            return new XRHandJoint { handedness = handedness, trackingState = trackingState, id = id, pose = pose, radius = radius,
                                     linearVelocity = linearVelocity, angularVelocity = angularVelocity };
        }
    }
}

namespace Godot
{
    public struct Vector3
    {
        public float X, Y, Z;
        public Vector3(float x, float y, float z) { X = x; Y = y; Z = z; }
    }

    public struct Quaternion
    {
        public float X, Y, Z, W;
        public Quaternion(float x, float y, float z, float w) { X = x; Y = y; Z = z; W = w; }
    }

    public struct Basis
    {
        public Quaternion Rotation;  // stand-in: Godot's Basis holds the 3x3 matrix of this rotation
        public Basis(Quaternion rotation) { Rotation = rotation; }
    }

    public struct Transform3D
    {
        public Basis Basis;
        public Vector3 Origin;
        public Transform3D(Basis basis, Vector3 origin) { Basis = basis; Origin = origin; }
    }

    public sealed class StringName
    {
        readonly string text;
        StringName(string text) { this.text = text; }
        public static implicit operator StringName(string text) { return new StringName(text); }
        public override string ToString() { return text; }
    }

    public class XRTracker
    {
        public StringName Name { get; set; }
    }

    public class XRPose
    {
        public enum TrackingConfidenceEnum : long { None = 0, Low = 1, High = 2 }
        public TrackingConfidenceEnum TrackingConfidence { get; set; }
    }

    public class XRPositionalTracker : XRTracker
    {
        public enum TrackerHand : long { Unknown = 0, Left = 1, Right = 2 }
        public TrackerHand Hand { get; set; }
        public readonly Dictionary<string, Transform3D> Poses = new Dictionary<string, Transform3D>();
        public void SetPose(StringName name, Transform3D transform, Vector3 linearVelocity, Vector3 angularVelocity, XRPose.TrackingConfidenceEnum trackingConfidence)
        {
            Poses[name.ToString()] = transform;
        }
        public void InvalidatePose(StringName name) { Poses.Remove(name.ToString()); }
    }

    public class XRHandTracker : XRPositionalTracker
    {
        // Godot .NET appends "Enum" to an enum named like a property of its class.
        public enum HandTrackingSourceEnum : long { Unknown = 0, Unobstructed = 1, Controller = 2, NotTracked = 3 }
        public enum HandJoint : long
        {
            Palm = 0, Wrist = 1, ThumbMetacarpal = 2, ThumbPhalanxProximal = 3, ThumbPhalanxDistal = 4, ThumbTip = 5,
            IndexFingerMetacarpal = 6, IndexFingerPhalanxProximal = 7, IndexFingerPhalanxIntermediate = 8, IndexFingerPhalanxDistal = 9, IndexFingerTip = 10,
            MiddleFingerMetacarpal = 11, MiddleFingerPhalanxProximal = 12, MiddleFingerPhalanxIntermediate = 13, MiddleFingerPhalanxDistal = 14, MiddleFingerTip = 15,
            RingFingerMetacarpal = 16, RingFingerPhalanxProximal = 17, RingFingerPhalanxIntermediate = 18, RingFingerPhalanxDistal = 19, RingFingerTip = 20,
            PinkyFingerMetacarpal = 21, PinkyFingerPhalanxProximal = 22, PinkyFingerPhalanxIntermediate = 23, PinkyFingerPhalanxDistal = 24, PinkyFingerTip = 25,
            Max = 26,
        }
        [Flags]
        public enum HandJointFlags : long
        {
            OrientationValid = 1, OrientationTracked = 2, PositionValid = 4, PositionTracked = 8, LinearVelocityValid = 16, AngularVelocityValid = 32,
        }

        public HandTrackingSourceEnum HandTrackingSource { get; set; }
        public bool HasTrackingData { get; set; }
        public readonly Transform3D[] Transforms = new Transform3D[26];
        public readonly HandJointFlags[] Flags = new HandJointFlags[26];
        public readonly float[] Radii = new float[26];
        public readonly Vector3[] LinearVelocities = new Vector3[26], AngularVelocities = new Vector3[26];
        public void SetHandJointTransform(HandJoint joint, Transform3D transform) { Transforms[(int)joint] = transform; }
        public void SetHandJointFlags(HandJoint joint, HandJointFlags flags) { Flags[(int)joint] = flags; }
        public void SetHandJointRadius(HandJoint joint, float radius) { Radii[(int)joint] = radius; }
        public void SetHandJointLinearVelocity(HandJoint joint, Vector3 velocity) { LinearVelocities[(int)joint] = velocity; }
        public void SetHandJointAngularVelocity(HandJoint joint, Vector3 velocity) { AngularVelocities[(int)joint] = velocity; }
    }

    public static class XRServer
    {
        public static readonly List<XRTracker> Trackers = new List<XRTracker>();
        public static void AddTracker(XRTracker tracker) { Trackers.Add(tracker); }
    }
}
