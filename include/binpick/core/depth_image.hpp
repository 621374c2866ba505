#pragma once
/// \file depth_image.hpp
/// Depth images: a non-owning strided view over caller memory and an owning image.
///
/// Integrators have depth in two encodings: 16-bit unsigned units (typically millimetres, 0 = no
/// measurement) and floating-point metres (0 or NaN = no measurement). A `DepthImageView` carries its
/// encoding, row stride [bytes] and scale [metres per stored unit], so an OpenCV `cv::Mat`, a camera
/// SDK buffer or a ROS image is wrapped without a copy or conversion:
/// \code
///   cv::Mat mm = cv::imread("d.png", cv::IMREAD_ANYDEPTH);                      // CV_16U
///   binpick::DepthImageView<float> view(mm.ptr<std::uint16_t>(), mm.cols, mm.rows, mm.step, 0.001f);
/// \endcode
/// Invalid depth: 0, negative or non-finite; `depth(u, v)` returns 0 for all of them, so invalid values
/// never propagate.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <cmath>
#include <vector>

#include "binpick/core/detail/simd.hpp"
#include "binpick/core/errors.hpp"

namespace binpick {

enum class DepthEncoding { uint16, float32, float64 };

template <typename Scalar>
class DepthImageView {
 public:
  DepthImageView() = default;

  /// 16-bit units: metres = value * metres_per_unit (e.g. 0.001 for millimetres).
  /// `row_stride_bytes` = 0 means tightly packed rows.
  DepthImageView(const std::uint16_t* data, int width, int height, std::ptrdiff_t row_stride_bytes,
                 Scalar metres_per_unit)
      : DepthImageView(data, DepthEncoding::uint16, sizeof(std::uint16_t), width, height, row_stride_bytes,
                       metres_per_unit) {}
  /// 32-bit float; `metres_per_unit` = 1 for metres.
  DepthImageView(const float* data, int width, int height, std::ptrdiff_t row_stride_bytes = 0,
                 Scalar metres_per_unit = Scalar(1))
      : DepthImageView(data, DepthEncoding::float32, sizeof(float), width, height, row_stride_bytes,
                       metres_per_unit) {}
  /// 64-bit float; `metres_per_unit` = 1 for metres.
  DepthImageView(const double* data, int width, int height, std::ptrdiff_t row_stride_bytes = 0,
                 Scalar metres_per_unit = Scalar(1))
      : DepthImageView(data, DepthEncoding::float64, sizeof(double), width, height, row_stride_bytes,
                       metres_per_unit) {}

  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return width_ == 0 || height_ == 0; }
  DepthEncoding encoding() const { return encoding_; }
  std::ptrdiff_t row_stride_bytes() const { return stride_; }
  Scalar metres_per_unit() const { return scale_; }
  const void* data() const { return data_; }

  /// Typed pointer to row v. `T` must match the encoding (checked in debug builds only).
  template <typename T>
  const T* row(int v) const {
    return reinterpret_cast<const T*>(static_cast<const unsigned char*>(data_) + stride_ * v);
  }

  /// Depth [m] at column u, row v; 0 when the pixel holds no valid measurement. No bounds check.
  Scalar depth(int u, int v) const {
    switch (encoding_) {
      case DepthEncoding::uint16: return decode(row<std::uint16_t>(v)[u], scale_);
      case DepthEncoding::float32: return decode(row<float>(v)[u], scale_);
      default: return decode(row<double>(v)[u], scale_);
    }
  }

  /// Calls f(T{}) with the stored element type, so hot loops can read rows without a per-pixel switch.
  template <typename F>
  decltype(auto) dispatch(F&& f) const {
    switch (encoding_) {
      case DepthEncoding::uint16: return f(std::uint16_t{});
      case DepthEncoding::float32: return f(float{});
      default: return f(double{});
    }
  }

  /// A stored value in metres, or 0 when it is invalid (0, negative, NaN, inf).
  template <typename T>
  static Scalar decode(T raw, Scalar metres_per_unit) {
    const Scalar d = Scalar(raw) * metres_per_unit;
    return (d > Scalar(0) && d < std::numeric_limits<Scalar>::infinity()) ? d : Scalar(0);
  }

 private:
  DepthImageView(const void* data, DepthEncoding enc, std::size_t elem, int width, int height,
                 std::ptrdiff_t row_stride_bytes, Scalar metres_per_unit)
      : data_(data), encoding_(enc), width_(width), height_(height),
        stride_(row_stride_bytes == 0 ? std::ptrdiff_t(elem) * width : row_stride_bytes), scale_(metres_per_unit) {
    require(width >= 0, "width", "must be >= 0");
    require(height >= 0, "height", "must be >= 0");
    require(data != nullptr || width == 0 || height == 0, "data", "is null for a non-empty image");
    require(stride_ >= std::ptrdiff_t(elem) * width, "row_stride_bytes", "is smaller than one row");
    require(std::isfinite(metres_per_unit) && metres_per_unit > Scalar(0), "metres_per_unit",
            "must be finite and > 0");
  }

  const void* data_ = nullptr;
  DepthEncoding encoding_ = DepthEncoding::float32;
  int width_ = 0, height_ = 0;
  std::ptrdiff_t stride_ = 0;
  Scalar scale_ = Scalar(1);
};

/// Owning depth image in metres (0 = no measurement), rows tightly packed.
template <typename Scalar>
class DepthImage {
 public:
  DepthImage() = default;
  DepthImage(int width, int height, Scalar fill = Scalar(0)) { resize(width, height, fill); }

  void resize(int width, int height, Scalar fill = Scalar(0)) {
    require(width >= 0, "width", "must be >= 0");
    require(height >= 0, "height", "must be >= 0");
    width_ = width;
    height_ = height;
    data_.assign(std::size_t(width) * std::size_t(height), fill);
  }

  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return data_.empty(); }
  Scalar& at(int u, int v) { return data_[std::size_t(v) * width_ + u]; }
  Scalar at(int u, int v) const { return data_[std::size_t(v) * width_ + u]; }
  Scalar* data() { return data_.data(); }
  const Scalar* data() const { return data_.data(); }
  std::vector<Scalar>& storage() { return data_; }
  const std::vector<Scalar>& storage() const { return data_; }

  /// Count of pixels with a valid (finite, > 0) depth.
  std::size_t valid_count() const {
    std::size_t n = 0;
    for (Scalar d : data_) n += (d > Scalar(0)) & (d < std::numeric_limits<Scalar>::infinity());  // &: vectorizes
    return n;
  }

  DepthImageView<Scalar> view() const { return DepthImageView<Scalar>(data_.data(), width_, height_); }

 private:
  int width_ = 0, height_ = 0;
  std::vector<Scalar> data_;
};

namespace detail {

BINPICK_SIMD_BEGIN

/// DepthImageView::decode for the Pack<Scalar, Bytes>::size raw values at `raw`: the depths [m], 0 in
/// the invalid lanes, and in `ok` the valid lanes (the scalar rule lane for lane, so the same bits).
/// For kernels that decode a row as they go instead of in a pass of their own.
template <typename Scalar, int Bytes, typename T>
BINPICK_SIMD_INLINE typename Pack<Scalar, Bytes>::type decode_pack(const T* raw, Scalar metres_per_unit,
                                                                   typename Pack<Scalar, Bytes>::mask& ok) {
  using P = Pack<Scalar, Bytes>;
  typename Lanes<T, P::size>::type r;
  std::memcpy(&r, raw, sizeof r);
  const typename P::type d = __builtin_convertvector(r, typename P::type) * P::splat(metres_per_unit);
  const typename P::type zero = P::splat(Scalar(0));
  ok = (d > zero) & (d < P::splat(std::numeric_limits<Scalar>::infinity()));  // NaN fails both
  return P::select(ok, d, zero);
}

BINPICK_SIMD_END

}  // namespace detail
}  // namespace binpick
