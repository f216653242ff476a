#pragma once
// Scenes built in code: capsules (a sphere swept along a segment, its radius changing
// linearly), the procedural hand made of them, a sphere; and the camera and lights that frame
// any mesh, including a user's scan.

#include "skinspec/render/renderer.hpp"

namespace skinspec::render {

// A capsule from a (radius ra) to b (radius rb); `segments` around, half as many per cap.
Mesh capsule(const Vec3& a, double ra, const Vec3& b, double rb, int segments);

// A left hand seen from its back, fingers up, about 19 cm long in centimetres: the palm a
// flattened capsule, four fingers of three tapering phalanges each, a thumb of three, a wrist.
Mesh procedural_hand();
Mesh sphere(const Vec3& centre, double radius, int segments);

// The camera on +z looking at the mesh's bounds so that they fill the frame, and two lights:
// a key light above-left of the camera and a dimmer point fill light to its right. With
// `aspect` = width / height.
Scene framed_scene(Mesh mesh, double aspect);

enum class SceneKind { hand, sphere };
Scene builtin_scene(SceneKind kind, double aspect);

}  // namespace skinspec::render
