#include "fuse/estimation/state_history.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>

namespace fuse {

namespace {
/// Two times closer than this are the same instant (1 µs: well below any sensor period).
constexpr double kSameTime = 1e-6;
}  // namespace

const char* to_string(QueryStatus status) {
  switch (status) {
    case QueryStatus::kNotInitialised: return "not_initialised";
    case QueryStatus::kCorrected: return "corrected";
    case QueryStatus::kPropagated: return "propagated";
    case QueryStatus::kTooOld: return "too_old";
    case QueryStatus::kInFuture: return "in_future";
  }
  return "unknown";
}

void StateHistoryConfig::load(ConfigNode& node) {
  node.get("length_s", length_s);
  node.check(std::isfinite(length_s) && length_s >= 0.5 && length_s <= 600.0, "length_s", "must be in [0.5, 600] s");
  node.finish();
}

NavState interpolate(const NavState& x0, const NavState& x1, double a) {
  NavState out = x0;
  out.p = (1.0 - a) * x0.p + a * x1.p;
  out.v = (1.0 - a) * x0.v + a * x1.v;
  out.R = x0.R * so3::Exp(a * so3::Log(x0.R.transpose() * x1.R));
  out.bg = (1.0 - a) * x0.bg + a * x1.bg;
  out.ba = (1.0 - a) * x0.ba + a * x1.ba;
  return out;
}

void level_with_accelerometer(const Eigen::Vector3d& f, double sigma, NavState& x, StateCovariance& P) {
  // Iterated EKF on the rotation block (right perturbation R = R̂·Exp(δθ)):
  //   h(x) = R_WIᵀu,  H = ∂h/∂δθ = [R_WIᵀu]×,  r = f/|f| − h(x_i),
  //   δx_{i+1} = K_i (r_i + H_i δx_i),  K_i = P Hᵢᵀ (H_i P_rr Hᵢᵀ + σ² I)⁻¹,
  // relinearised at x_i = x̂ ⊞ δx_i (a gap can leave tens of degrees to correct), P ← (I − K H) P.
  constexpr int kIterations = 5;
  if (!(f.norm() > 0.0) || !(sigma > 0.0)) return;
  const Eigen::Vector3d z = f.normalized();
  const Eigen::Vector3d u = -x.g.normalized();
  const NavState x0 = x;
  StateVector dx = StateVector::Zero();
  Eigen::Matrix<double, kStateDim, 3> K;
  Eigen::Matrix3d H;
  for (int i = 0; i < kIterations; ++i) {
    const Eigen::Vector3d h = x.R.transpose() * u;
    H = so3::hat(h);
    const Eigen::Matrix3d S = H * P.block<3, 3>(Idx::kRot, Idx::kRot) * H.transpose() +
                              sigma * sigma * Eigen::Matrix3d::Identity();
    K = P.middleCols<3>(Idx::kRot) * H.transpose() * S.inverse();
    dx = K * (z - h + H * dx.segment<3>(Idx::kRot));
    x = x0.boxplus(dx);
  }
  const StateCovariance KHP = K * H * P.middleRows<3>(Idx::kRot);
  P -= KHP;
  P = 0.5 * (P + P.transpose()).eval();
}

StateVector unmodelled_motion_variance(double accel_std, double gyro_std, double dt) {
  StateVector q = StateVector::Zero();
  q.segment<3>(Idx::kPos).setConstant(std::pow(0.5 * accel_std * dt * dt, 2));
  q.segment<3>(Idx::kVel).setConstant(std::pow(accel_std * dt, 2));
  q.segment<3>(Idx::kRot).setConstant(std::pow(gyro_std * dt, 2));
  return q;
}

StateVector EntryStep::coast_variance(double t_prev, double t) const {
  if (!coasts()) return StateVector::Zero();
  // V(t − a) − V(t_prev − a): V grows with the time since the anchor, so this is never negative.
  const double from = std::max(t_prev - coast_from, 0.0), to = std::max(t - coast_from, from);
  return unmodelled_motion_variance(coast_accel_std, coast_gyro_std, to) -
         unmodelled_motion_variance(coast_accel_std, coast_gyro_std, from);
}

void EntryStep::apply(NavState& x, StateCovariance& P, double t_prev, double t) const {
  P.diagonal() += q + coast_variance(t_prev, t);
  if (level_sigma > 0.0) level_with_accelerometer(level_accel - x.ba, level_sigma, x, P);
}

Eigen::Vector3d StateHistory::step_accel(const Entry& prev, const Eigen::Vector3d& next_accel) {
  // A coasted step: the specific force that cancels gravity in the attitude the step starts
  // from, as it is now (after any correction before it), f = R⊤(−g) + b_a.
  if (prev.coasting) return prev.x.R.transpose() * (-prev.x.g) + prev.x.ba;
  return 0.5 * (prev.accel + next_accel);
}

ReadingChange StateHistory::step_change(const Entry& prev, const Entry& next) {
  if (prev.coasting) return {};
  return {next.gyro_smooth - prev.gyro_smooth};
}

Eigen::Vector3d StateHistory::smooth_gyro(double t, double td, const Eigen::Vector3d& gyro) {
  const double tau = noise_.time_offset_rate_smoothing_s;
  const double stamp = t + td;
  const double dt = stamp - gyro_smooth_stamp_;
  if (std::isnan(dt) || tau <= 0.0) {
    gyro_smooth_ = gyro;  // the first sample starts the low-pass at its reading; τ = 0: raw
  } else if (dt > 0.0) {
    const double keep = std::exp(-dt / tau);
    gyro_smooth_ = keep * gyro_smooth_ + (1.0 - keep) * gyro;
  }  // a second sample at the same instant leaves it (it has had its time)
  gyro_smooth_stamp_ = std::isnan(dt) || dt > 0.0 ? stamp : gyro_smooth_stamp_;
  return gyro_smooth_;
}

void StateHistory::mark_newest_coasting() { entries_.back().coasting = true; }

void StateHistory::reset(double t, const NavState& x, const StateCovariance& P, const ImuSample& held,
                         double rest_since) {
  entries_.clear();
  entries_.push_back({t, x, P, held.gyro, held.accel, EntryStep{}, false, held.gyro});
  gyro_smooth_ = held.gyro;
  gyro_smooth_stamp_ = t + x.td;
  stale_from_ = entries_.size();
  last_correction_t_ = t;
  rest_since_ = rest_since < t ? rest_since : std::numeric_limits<double>::quiet_NaN();
}

void StateHistory::assign(const std::vector<Entry>& entries, double last_correction_t) {
  rest_since_ = std::numeric_limits<double>::quiet_NaN();
  entries_.assign(entries.begin(), entries.end());
  gyro_smooth_ = entries_.empty() ? Eigen::Vector3d::Zero() : entries_.back().gyro_smooth;
  gyro_smooth_stamp_ =
      entries_.empty() ? std::numeric_limits<double>::quiet_NaN() : entries_.back().t + entries_.back().x.td;
  stale_from_ = entries_.size();
  last_correction_t_ = last_correction_t;
}

void StateHistory::refresh_to(std::size_t k) const {
  for (; stale_from_ <= k && stale_from_ < entries_.size(); ++stale_from_) {
    const Entry& prev = entries_[stale_from_ - 1];
    Entry& cur = entries_[stale_from_];
    cur.x = prev.x;
    cur.P = prev.P;
    propagate(cur.x, &cur.P, 0.5 * (prev.gyro + cur.gyro), step_accel(prev, cur.accel), cur.t - prev.t, noise_,
              step_change(prev, cur));
    cur.step.apply(cur.x, cur.P, prev.t, cur.t);
  }
}

void StateHistory::add_imu(const ImuSample& imu) {
  const double placed_with = time_offset();  // the offset the caller placed the sample with
  const double dt = imu.t - entries_.back().t;
  if (dt > kSameTime) {
    if (stale_entries() <= kEagerRefresh) refresh_to(entries_.size() - 1);
    const bool fresh = stale_entries() == 0;
    const Entry& prev = entries_.back();
    Entry next = prev;  // a stale tail: the state is recomputed when read
    next.coasting = false;
    next.t = imu.t;
    next.step = EntryStep{};
    next.gyro = imu.gyro;
    next.accel = imu.accel;
    next.gyro_smooth = smooth_gyro(imu.t, placed_with, imu.gyro);
    if (fresh) {
      propagate(next.x, &next.P, 0.5 * (prev.gyro + imu.gyro), step_accel(prev, imu.accel), dt, noise_,
                step_change(prev, next));
    }
    entries_.push_back(next);
    if (fresh) stale_from_ = entries_.size();
    trim();
  } else {
    // Same instant as the newest entry (e.g. a scan end entry): only the held measurement changes.
    entries_.back().gyro = imu.gyro;
    entries_.back().accel = imu.accel;
    entries_.back().coasting = false;
    entries_.back().gyro_smooth = smooth_gyro(imu.t, placed_with, imu.gyro);
  }
}

std::size_t StateHistory::find_at_or_before(double t) const {
  // Index of the last entry with entry.t <= t + kSameTime (entries_ is sorted by time).
  auto it = std::upper_bound(entries_.begin(), entries_.end(), t + kSameTime,
                             [](double value, const Entry& e) { return value < e.t; });
  return static_cast<std::size_t>(std::distance(entries_.begin(), it)) - 1;
}

bool StateHistory::ensure_entry(double t) {
  if (entries_.empty()) return false;
  if (t < entries_.front().t - kSameTime) {
    if (!(t >= rest_since_ - kSameTime)) return false;  // NaN: no rest known before the oldest
    // After the sample before the initialising one: the sensor rested, so the state at t is the
    // oldest one, and the step from t to it is motionless.
    Entry rest = entries_.front();
    rest.t = t;
    rest.step = EntryStep{};
    rest.coasting = false;
    const ImuSample still = rest_measurement(rest.x, t);
    rest.gyro = still.gyro;
    rest.accel = still.accel;
    entries_.push_front(rest);
    ++stale_from_;
    return true;
  }
  const std::size_t i = find_at_or_before(t);
  if (std::abs(entries_[i].t - t) <= kSameTime) return true;
  refresh_to(i);
  const Entry& base = entries_[i];
  // Split the step [base.t, next.t] at t: the first part with the held measurement.
  Entry mid = base;
  propagate(mid.x, &mid.P, base.gyro, base.coasting ? step_accel(base, base.accel) : base.accel, t - base.t, noise_);
  mid.t = t;
  mid.step = EntryStep{};  // what the step [base.t, next.t] brings stays at its end, but for
  if (i + 1 < entries_.size() && entries_[i + 1].step.coasts()) {
    // a coast's unmodelled motion, which accrues along the step: its part up to t is here.
    mid.step.take_coast(entries_[i + 1].step);
    mid.step.apply(mid.x, mid.P, base.t, t);
  }
  const bool was_fresh = stale_entries() == 0;
  entries_.insert(entries_.begin() + static_cast<std::ptrdiff_t>(i) + 1, mid);
  // The entries after the split moved by one; the step after it now starts at t with the same
  // held input: re-propagate from there.
  stale_from_ = was_fresh ? entries_.size() : stale_from_ + 1;
  repropagate_from(i + 1);
  if (stale_entries() <= kEagerRefresh) refresh_to(entries_.size() - 1);
  return true;
}

void StateHistory::correct(double t, const NavState& x, const StateCovariance& P) {
  const std::size_t i = find_at_or_before(t);
  refresh_to(i);  // what lies before the correction must not be recomputed over it later
  const double moved = x.td - entries_[i].x.td;
  entries_[i].x = x;
  entries_[i].P = P;
  entries_[i].step = EntryStep{};  // the posterior includes it
  if (moved != 0.0) {
    // The IMU samples after t were placed with the old time offset (t = t_imu − t_d): they move
    // by −Δt_d, and those that land at or before t are dropped (t holds their time now).
    std::size_t kept = i + 1;
    for (std::size_t k = i + 1; k < entries_.size(); ++k) {
      entries_[k].t -= moved;
      if (entries_[k].step.coasts()) entries_[k].step.coast_from -= moved;
      if (entries_[k].t > entries_[i].t + kSameTime) entries_[kept++] = entries_[k];
    }
    entries_.erase(entries_.begin() + static_cast<std::ptrdiff_t>(kept), entries_.end());
    stale_from_ = std::min(stale_from_, entries_.size());
  }
  for (std::size_t k = i + 1; k < entries_.size(); ++k) {
    // The posterior measured the pose at t: a coast across t is unmodelled from t on.
    EntryStep& later = entries_[k].step;
    if (later.coasts() && later.coast_from < entries_[i].t) later.coast_from = entries_[i].t;
  }
  repropagate_from(i);
  if (stale_entries() <= kEagerRefresh) refresh_to(entries_.size() - 1);
  last_correction_t_ = std::max(last_correction_t_, t);
}

void StateHistory::add_step_to_newest(const EntryStep& step) {
  refresh_to(entries_.size() - 1);
  Entry& e = entries_.back();
  const double t_prev = entries_.size() > 1 ? entries_[entries_.size() - 2].t : e.t;
  step.apply(e.x, e.P, t_prev, e.t);
  e.step.q += step.q;
  if (step.coasts()) e.step.take_coast(step);
  if (step.level_sigma > 0.0) {
    e.step.level_accel = step.level_accel;
    e.step.level_sigma = step.level_sigma;
  }
}

void StateHistory::inflate(double t, const StateVector& q) {
  const std::size_t i = find_at_or_before(t);
  refresh_to(i);
  entries_[i].P.diagonal() += q;
  entries_[i].step.q += q;
  repropagate_from(i);
  if (stale_entries() <= kEagerRefresh) refresh_to(entries_.size() - 1);
}

void StateHistory::transform_world(const Eigen::Isometry3d& T_new_old) {
  // x' = T ⊕ x: p' = R p + t, v' = R v, R'_WI = R R_WI, g' = R g. The error state's position,
  // velocity and gravity parts are world-frame vectors and turn with R (δp' = R δp); rotation
  // errors are body-frame (δθ_WI) and stay. Gravity's 2-D tangent error is left as it is: the
  // transforms used turn about the vertical up to the two frames' tilt (a degree at most), which
  // keeps g and its tangent basis nearly as they were.
  if (entries_.empty()) return;
  refresh_to(entries_.size() - 1);
  const Eigen::Matrix3d R = T_new_old.linear();
  StateCovariance J = StateCovariance::Identity();
  J.block<3, 3>(Idx::kPos, Idx::kPos) = R;
  J.block<3, 3>(Idx::kVel, Idx::kVel) = R;
  for (Entry& e : entries_) {
    e.x.p = R * e.x.p + T_new_old.translation();
    e.x.v = R * e.x.v;
    e.x.R = so3::Normalize(R * e.x.R);
    e.x.g = R * e.x.g;
    e.P = J * e.P * J.transpose();
  }
}

StateQuery StateHistory::query(double t) const {
  StateQuery q;
  q.t = t;
  if (entries_.empty()) return q;
  if (!std::isfinite(t) || t < entries_.front().t - kSameTime) {
    q.status = QueryStatus::kTooOld;
    if (!std::isfinite(t)) q.status = QueryStatus::kInFuture;
    return q;
  }
  if (t > entries_.back().t + kSameTime) {
    q.status = QueryStatus::kInFuture;
    return q;
  }
  const std::size_t i = find_at_or_before(t);
  refresh_to(i + 1);
  const Entry& e0 = entries_[i];
  if (i + 1 >= entries_.size() || std::abs(e0.t - t) <= kSameTime) {
    q.x = e0.x;
    q.P = e0.P;
  } else {
    const Entry& e1 = entries_[i + 1];
    const double a = (t - e0.t) / (e1.t - e0.t);
    q.x = interpolate(e0.x, e1.x, a);
    q.P = (1.0 - a) * e0.P + a * e1.P;
  }
  q.omega = e0.gyro - q.x.bg;  // the rate propagation integrates from e0 on
  q.status = t <= last_correction_t_ + kSameTime ? QueryStatus::kCorrected : QueryStatus::kPropagated;
  return q;
}

double StateHistory::measured_since(double t0, double t1, double max_step) const {
  double since = t0;
  if (entries_.empty() || t1 < entries_.front().t) return since;
  for (std::size_t i = t0 < entries_.front().t ? 0 : find_at_or_before(t0); i + 1 < entries_.size(); ++i) {
    const double a = entries_[i].t, b = entries_[i + 1].t;
    if (b > t1 + kSameTime) break;
    if (b > t0 && b < t1 - kSameTime && b - a > max_step) since = b;
  }
  return since;
}

std::vector<const StateHistory::Entry*> StateHistory::entries_between(double t0, double t1) const {
  std::vector<const Entry*> out;
  if (entries_.empty() || std::isnan(t0) || std::isnan(t1)) return out;
  if (t1 >= entries_.front().t - kSameTime) refresh_to(find_at_or_before(t1));
  // Sorted by time: from the first entry at or after t0 on, not through all of them (each entry
  // holds its covariance, kilobytes apart: a walk over five seconds of them missed the cache
  // a thousand times per call).
  auto it = std::lower_bound(entries_.begin(), entries_.end(), t0 - kSameTime,
                             [](const Entry& e, double value) { return e.t < value; });
  for (; it != entries_.end() && it->t <= t1 + kSameTime; ++it) out.push_back(&*it);
  return out;
}

std::vector<const StateHistory::Entry*> StateHistory::entries_covering(double t0, double t1) const {
  if (entries_.empty() || std::isnan(t0)) return {};
  const auto after = std::upper_bound(entries_.begin(), entries_.end(), t0, [](double value, const Entry& e) { return value < e.t; });
  return entries_between(after == entries_.begin() ? entries_.front().t : std::prev(after)->t, t1);
}

void StateHistory::trim() {
  const double keep_from = entries_.back().t - config_.length_s;
  std::size_t n = 0;  // entries to drop from the front
  while (entries_.size() - n > 2 && entries_[n + 1].t < keep_from) ++n;
  if (n == 0) return;
  rest_since_ = std::numeric_limits<double>::quiet_NaN();  // the rest's end is no longer kept
  refresh_to(n);  // the new oldest entry must be up to date: nothing before it is kept
  entries_.erase(entries_.begin(), entries_.begin() + static_cast<std::ptrdiff_t>(n));
  stale_from_ -= n;
}

}  // namespace fuse
