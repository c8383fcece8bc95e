#pragma once
#include "durer/math/Vec.h"

namespace durer {

// A light's size (a point or spot light's radius, a directional light's angle) and its soft
// shadows: its term unchanged, times the share of it that reaches a shaded hit — of `samples`
// shadow rays toward points spread uniformly over the cone it subtends there, those nothing blocks,
// weighted by their cosines with the normal. Size 0, or not `sampled`: hard shadows from its
// centre, one ray. Either way its highlights spread over the cone (PacketShader::lightTerm).
struct SoftShadows {
  double size = 0;  // a sphere's radius (point, spot), or a cone's half angle in radians (directional)
  int samples = 1;  // in [1, RenderLimits::raysPerHit]
  bool sampled = true;
  bool on() const { return sampled && size > 0; }  // its shadows sampled over it
};

struct DirectionalLight {
  Vec3d direction;       // unit, world space: the way the light travels (the surface sees it from -direction)
  Vec3d color;           // linear RGB, no falloff
  bool shadows = false;  // whether occluders block it (shadow rays are cast only for such lights)
  SoftShadows soft;      // size: half the angle the light's disc spans, in [0, π/2)
};

// Point and spot lights fall off as color / (c0 + c1·d + c2·d²) at distance d: (1, 0, 0) is the
// 6.837 assignment-2 light (no falloff), (0, 0, 1) the physical inverse square (Cycles).
struct PointLight {
  Vec3d position;            // world space
  Vec3d color;               // linear RGB
  Vec3d attenuation{1, 0, 0};  // c0, c1, c2 >= 0, not all 0
  bool shadows = false;      // whether occluders block it
  SoftShadows soft;          // size: the radius of the sphere it shines from (its light unchanged)
};

// A point light restricted to a cone, its edge softened as Blender's (Cycles') spot blend:
// smoothstep((cosθ - cos(halfAngle)) / ((1 - cos(halfAngle))·blend)), a hard edge for blend 0.
struct SpotLight {
  Vec3d position;            // world space
  Vec3d direction;           // unit, world space: the cone's axis, the way it shines
  Vec3d color;               // linear RGB on the axis
  Vec3d attenuation{1, 0, 0};  // as PointLight
  double cosHalfAngle = 0;   // cos of the half opening angle, in (-1, 1)
  double blend = 0;          // [0, 1]
  bool shadows = false;
  SoftShadows soft;          // as PointLight
};

// A one-sided Lambertian emitter (Blender's area light): the parallelogram centred at `position`
// spanned by the edge vectors `u` and `v`, or the ellipse inscribed in it, shining toward u × v.
// `color` is its radiant intensity along that normal in a point light's units, so that far away it
// is a point light of colour color·cosθ with inverse-square falloff; near it, a shaded point
// receives the integral over the surface, estimated from `samples` points on it (stratified; a
// rectangle's uniform in the solid angle it fills, an ellipse's near its plane in its rectangle's,
// farther off and a parallelogram's over its area; a shadow ray toward each where it casts
// shadows), and its shadows are soft. A mirror sees it along its mirror direction.
struct AreaLight {
  Vec3d position;  // world space, the centre
  Vec3d u, v;      // world space, full edge lengths; u × v != 0
  Vec3d color;     // linear RGB: radiant intensity along u × v
  bool ellipse = false;
  int samples = 16;  // points per shaded hit, in [1, RenderLimits::raysPerHit]
  bool shadows = false;
};

}  // namespace durer
