// The explicit instantiations declared in sim_instances.hpp, faulty_drivers.hpp and sim_cell.hpp.
#include "sim_cell.hpp"

template class binpick::Fuser<float, binpick::PinholeCamera<float>>;
template class binpick::Fuser<double, binpick::PinholeCamera<double>>;
template class binpick::sim::Scene<float>;
template class binpick::sim::StereoSensor<float>;
template class binpick::sim::FakeSensor<float>;
template class binpick::sim::FakeRobot<float>;
template class binpick::sim::ReferenceEstimator<float, binpick::PinholeCamera<float>>;
template class binpick::simcell::FaultyRobot<float>;
template class binpick::simcell::FaultySensor<float>;
template class binpick::simcell::SimGripper<float>;
template class binpick::cycle::PickingPipeline<
    binpick::simcell::FaultyRobot<float>, binpick::simcell::FaultySensor<float>,
    binpick::sim::ReferenceEstimator<float, binpick::PinholeCamera<float>>, binpick::sim::SimClock,
    binpick::simcell::SimGripper<float>>;
