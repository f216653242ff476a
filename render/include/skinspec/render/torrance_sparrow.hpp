#pragma once
// The reflection model of the seed paper (eq. 2-5, after Torrance & Sparrow 1967 and Tominaga &
// Tanaka 2003): a Lambertian body term and a specular term from a Gaussian distribution of
// mirror-like microfacets. Every function here is wavelength-independent; the spectra multiply
// in afterwards (see Shading).

#include "skinspec/render/vec3.hpp"

namespace skinspec::render {

struct SurfaceParams {
  double alpha = 1.0;       // weight of the body (diffuse) term
  double beta = 4.0;        // weight of the specular term
  double roughness = 0.25;  // gamma: the facet angle (radians) at which D falls to one half
  double index = 1.4;       // n: refractive index of the skin surface (stratum corneum ~1.4-1.55)
};

// Eq. 3: D = exp(-ln 2 phi^2 / gamma^2), phi the angle between N and the facet normal Q.
double facet_distribution(double phi, double roughness);

// Eq. 4, the Fresnel reflectance of unpolarised light for cos(theta_Q) = c:
// F = 1/2 (g-c)^2/(g+c)^2 {1 + [c(g+c)-1]^2 / [c(g-c)+1]^2}, g = sqrt(n^2 + c^2 - 1).
// (The paper prints g as sqrt(n^2 + cos^2) - 1; the -1 belongs under the root, as in Cook and
// Torrance, or F would not be ((n-1)/(n+1))^2 at normal incidence.)
double fresnel(double cos_theta_q, double index);

// Eq. 5: G = min{1, 2 cos(phi) cos(theta_r) / cos(theta_Q), 2 cos(phi) cos(theta_i) / cos(theta_Q)}.
double geometric_attenuation(double cos_phi, double cos_theta_r, double cos_theta_i, double cos_theta_q);

// The two geometric factors of eq. 2 for one light: Y = body R E + specular E.
struct Shading {
  double body = 0;      // alpha (N.L)
  double specular = 0;  // beta D F G / (N.V)
};

// n: unit surface normal; to_light, to_viewer: unit vectors from the surface point. Zero when
// the light is behind the surface or the surface faces away from the viewer.
Shading torrance_sparrow(const Vec3& n, const Vec3& to_light, const Vec3& to_viewer, const SurfaceParams& surface);

}  // namespace skinspec::render
