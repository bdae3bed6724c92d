/// @file reconfigure_server.hpp
/// @brief The dynamic_reconfigure protocol (~set_parameters, ~parameter_descriptions,
/// ~parameter_updates) for a generated ConfigType, with one difference from
/// dynamic_reconfigure::Server: a value outside its range is refused and the old value kept,
/// where the library's server clamps it to the nearest bound before the node sees it and so
/// rewrites what the user asked for. Messages, descriptions and the generated config class are
/// still dynamic_reconfigure's; `dynparam` and rqt_reconfigure work with it unchanged.
#pragma once

#include <dynamic_reconfigure/Config.h>
#include <dynamic_reconfigure/ConfigDescription.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <ros/console.h>
#include <ros/node_handle.h>

#include <functional>
#include <mutex>

namespace constrained_particles
{
/// Serves one generated dynamic_reconfigure ConfigType.
template <typename ConfigType>
class ReconfigureServer
{
public:
  /// Applies a requested configuration: `current` is what the server showed, `requested` that
  /// with the request's fields put in (the callback applies the fields that differ). Returns
  /// false to refuse it, in which case the current configuration stays; on success it sets
  /// `in_force` to the configuration now in force. Must not call back into the server.
  using Callback = std::function<bool(const ConfigType& current, const ConfigType& requested,
                                      ConfigType& in_force)>;

  /// Advertises ~set_parameters and the two latched topics, with `initial` as the current
  /// configuration. Reads nothing from and writes nothing to the parameter server: start-up
  /// parameters stay as the user set them.
  ReconfigureServer(const ros::NodeHandle& nh, const ConfigType& initial, Callback callback)
    : nh_(nh), callback_(std::move(callback)), config_(initial)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    description_publisher_ =
        nh_.advertise<dynamic_reconfigure::ConfigDescription>("parameter_descriptions", 1, true);
    description_publisher_.publish(ConfigType::__getDescriptionMessage__());
    update_publisher_ = nh_.advertise<dynamic_reconfigure::Config>("parameter_updates", 1, true);
    publishLocked();
    service_ = nh_.advertiseService("set_parameters", &ReconfigureServer::setCallback, this);
  }

  /// Shows a configuration the node changed itself (a scene's settings after ~reset).
  void update(const ConfigType& config)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    config_ = config;
    publishLocked();
  }

  /// The configuration in force.
  ConfigType current() const
  {
    std::lock_guard<std::mutex> lock(mutex_);
    return config_;
  }

private:
  bool setCallback(dynamic_reconfigure::Reconfigure::Request& request,
                   dynamic_reconfigure::Reconfigure::Response& response)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // unnamed fields keep their values; no __clamp__(): the callback refuses what is out of range
    ConfigType requested = config_;
    // false when a field is unknown or sent with the wrong type (the generated code logs them):
    // the whole request is refused rather than applied in part
    if (!requested.__fromMessage__(request.config))
      ROS_ERROR_NAMED("reconfigure",
                      "~set_parameters refused: a field above is not a parameter "
                      "of this node or has the wrong type; nothing was changed");
    else
    {
      ConfigType in_force = requested;
      if (callback_(config_, requested, in_force))
        config_ = in_force;
    }
    publishLocked();
    config_.__toMessage__(response.config);
    return true;
  }

  void publishLocked()
  {
    dynamic_reconfigure::Config message;
    config_.__toMessage__(message);
    update_publisher_.publish(message);
  }

  ros::NodeHandle nh_;
  Callback callback_;
  mutable std::mutex mutex_;
  ConfigType config_;
  ros::Publisher description_publisher_, update_publisher_;
  ros::ServiceServer service_;
};

}  // namespace constrained_particles
