// Minimal 3-vector arithmetic shared by the stages (host and, later, device).
#pragma once

#include <cmath>
#include <cstddef>

#ifdef __CUDACC__
#define VPR_HD __host__ __device__
#else
#define VPR_HD
#endif

namespace vpr {

template <class T>
struct Vec3T {
  T x = 0, y = 0, z = 0;
};
using Vec3 = Vec3T<float>;
using Vec3d = Vec3T<double>;

template <class T>
VPR_HD inline Vec3T<T> operator+(Vec3T<T> a, Vec3T<T> b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <class T>
VPR_HD inline Vec3T<T> operator-(Vec3T<T> a, Vec3T<T> b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class T>
VPR_HD inline Vec3T<T> operator*(Vec3T<T> a, T s) {
  return {a.x * s, a.y * s, a.z * s};
}
template <class T>
VPR_HD inline Vec3T<T> operator*(T s, Vec3T<T> a) {
  return a * s;
}
template <class T>
VPR_HD inline T dot(Vec3T<T> a, Vec3T<T> b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <class T>
VPR_HD inline Vec3T<T> cross(Vec3T<T> a, Vec3T<T> b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T>
VPR_HD inline T norm2(Vec3T<T> a) {
  return dot(a, a);
}
template <class T>
VPR_HD inline T norm(Vec3T<T> a) {
  return std::sqrt(dot(a, a));
}

// Point i of a flat #N x 3 float array.
VPR_HD inline Vec3 load3(const float* p, size_t i) {
  return {p[3 * i], p[3 * i + 1], p[3 * i + 2]};
}
VPR_HD inline Vec3d load3d(const float* p, size_t i) {
  return {double(p[3 * i]), double(p[3 * i + 1]), double(p[3 * i + 2])};
}
VPR_HD inline void store3(float* p, size_t i, Vec3 v) {
  p[3 * i] = v.x;
  p[3 * i + 1] = v.y;
  p[3 * i + 2] = v.z;
}

}  // namespace vpr
