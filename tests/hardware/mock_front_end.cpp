// umockdev-backed USB front end for the hardware tests (see mock_front_end.hpp).
#include "mock_front_end.hpp"

#include <linux/capability.h>
#include <linux/usbdevice_fs.h>
#include <sys/ioctl.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstring>
#include <stdexcept>

namespace pvdf_test {

namespace proto = pvdf::hardware::protocol;

MockFrontEnd::MockFrontEnd(MockScript script) : script_(std::move(script)) {
  testbed_ = umockdev_testbed_new();
  const std::string vid = [&] { char t[8]; std::snprintf(t, sizeof t, "%04x", script_.vendor_id); return std::string(t); }();
  const std::string pid = [&] { char t[8]; std::snprintf(t, sizeof t, "%04x", script_.product_id); return std::string(t); }();
  // sysfs attributes end with a newline, as the kernel writes them.
  const std::string description =
      "P: /devices/pci0000:00/0000:00:14.0/usb1/1-1\n"
      "N: bus/usb/001/002\n"
      "E: SUBSYSTEM=usb\nE: DEVTYPE=usb_device\nE: DEVNAME=/dev/bus/usb/001/002\nE: BUSNUM=001\nE: DEVNUM=002\n"
      "A: busnum=1\\n\nA: devnum=2\\n\nA: speed=480\\n\nA: bConfigurationValue=1\\n\n"
      "A: idVendor=" + vid + "\\n\nA: idProduct=" + pid + "\\n\n";
  GError* error = nullptr;
  if (!umockdev_testbed_add_from_string(testbed_, description.c_str(), &error))
    throw std::runtime_error(std::string("umockdev: ") + (error ? error->message : "add_from_string failed"));
  syspath_ = "/sys/devices/pci0000:00/0000:00:14.0/usb1/1-1";
  // Device, configuration, interface (vendor class) and bulk-IN endpoint 0x81 descriptors.
  std::uint8_t descriptors[] = {
      18, 1, 0x00, 0x02, 0xFF, 0, 0, 64,
      static_cast<std::uint8_t>(script_.vendor_id), static_cast<std::uint8_t>(script_.vendor_id >> 8),
      static_cast<std::uint8_t>(script_.product_id), static_cast<std::uint8_t>(script_.product_id >> 8),
      0x00, 0x01, 0, 0, 0, 1,
      9, 2, 25, 0, 1, 1, 0, 0x80, 50,
      9, 4, 0, 0, 1, 0xFF, 0, 0, 0,
      7, 5, proto::bulk_in_endpoint, 2, 0x00, 0x02, 0};
  umockdev_testbed_set_attribute_binary(testbed_, syspath_.c_str(), "descriptors", descriptors,
                                        static_cast<gint>(sizeof descriptors));
  handler_ = umockdev_ioctl_base_new();
  g_signal_connect(handler_, "handle-ioctl", G_CALLBACK(&MockFrontEnd::on_ioctl), this);
  if (!umockdev_testbed_attach_ioctl(testbed_, "/dev/bus/usb/001/002", handler_, &error))
    throw std::runtime_error(std::string("umockdev: ") + (error ? error->message : "attach_ioctl failed"));
}

MockFrontEnd::~MockFrontEnd() {
  umockdev_testbed_detach_ioctl(testbed_, "/dev/bus/usb/001/002", nullptr);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto* d : held_) g_object_unref(d);
    for (auto* d : reapable_) g_object_unref(d);
    held_.clear();
    reapable_.clear();
  }
  g_object_unref(handler_);
  g_object_unref(testbed_);
}

std::string MockFrontEnd::node_path() const {
  gchar* root = umockdev_testbed_get_root_dir(testbed_);
  std::string path = std::string(root) + "/dev/bus/usb/001/002";
  g_free(root);
  return path;
}

std::string MockFrontEnd::sysfs_path() const {
  gchar* root = umockdev_testbed_get_root_dir(testbed_);
  std::string path = std::string(root) + syspath_;
  g_free(root);
  return path;
}

std::vector<ControlSeen> MockFrontEnd::controls() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return controls_;
}
int MockFrontEnd::peak_bulk_in_flight() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return peak_bulk_outstanding_;
}
std::size_t MockFrontEnd::chunks_sent() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return next_chunk_;
}
bool MockFrontEnd::disconnected() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return disconnected_;
}

gboolean MockFrontEnd::on_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self) {
  return static_cast<MockFrontEnd*>(self)->handle(client);
}

void MockFrontEnd::disconnect_locked() {
  // What the kernel does when the device goes away: URBs still queued complete with
  // -ESHUTDOWN (reapable, CAP_REAP_AFTER_DISCONNECT), every later ioctl fails with ENODEV.
  disconnected_ = true;
  running_ = false;
  for (auto* d : held_) {
    auto* urb = reinterpret_cast<usbdevfs_urb*>(d->data);
    urb->status = -ESHUTDOWN;
    urb->actual_length = 0;
    reapable_.push_back(d);
  }
  held_.clear();
  // The device also leaves sysfs and /dev, with a "remove" uevent, as an unplugged one does.
  umockdev_testbed_remove_device(testbed_, syspath_.c_str());
}

gboolean MockFrontEnd::handle(UMockdevIoctlClient* client) {
  const gulong request = umockdev_ioctl_client_get_request(client);
  UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
  std::lock_guard<std::mutex> lock(mutex_);
  if (request == USBDEVFS_DISCARDURB) {
    const gulong address = *reinterpret_cast<const gulong*>(arg->data);
    for (auto it = held_.begin(); it != held_.end(); ++it) {
      if ((*it)->client_addr != address) continue;
      auto* urb = reinterpret_cast<usbdevfs_urb*>((*it)->data);
      urb->status = -ENOENT;
      urb->actual_length = 0;
      reapable_.push_back(*it);
      held_.erase(it);
      umockdev_ioctl_client_complete(client, 0, 0);
      return TRUE;
    }
    umockdev_ioctl_client_complete(client, -1, EINVAL);
    return TRUE;
  }
  GError* error = nullptr;
  UMockdevIoctlData* data = umockdev_ioctl_data_resolve(arg, 0, _IOC_SIZE(request), &error);
  if (data == nullptr) {
    g_clear_error(&error);
    umockdev_ioctl_client_complete(client, -1, EFAULT);
    return TRUE;
  }
  switch (request) {
    case USBDEVFS_REAPURB:
    case USBDEVFS_REAPURBNDELAY: {
      if (reapable_.empty()) {
        umockdev_ioctl_client_complete(client, -1, disconnected_ ? ENODEV : EAGAIN);
        return TRUE;
      }
      UMockdevIoctlData* urb = reapable_.front();
      reapable_.pop_front();
      if (reinterpret_cast<usbdevfs_urb*>(urb->data)->type == USBDEVFS_URB_TYPE_BULK) --bulk_outstanding_;
      umockdev_ioctl_data_set_ptr(data, 0, urb);
      g_object_unref(urb);
      umockdev_ioctl_client_complete(client, 0, 0);
      return TRUE;
    }
    default:
      break;
  }
  if (disconnected_) {
    umockdev_ioctl_client_complete(client, -1, ENODEV);
    return TRUE;
  }
  switch (request) {
    case USBDEVFS_GET_CAPABILITIES:
      *reinterpret_cast<std::uint32_t*>(data->data) =
          USBDEVFS_CAP_BULK_CONTINUATION | USBDEVFS_CAP_NO_PACKET_SIZE_LIM | USBDEVFS_CAP_REAP_AFTER_DISCONNECT;
      umockdev_ioctl_client_complete(client, 0, 0);
      return TRUE;
    case USBDEVFS_CLAIMINTERFACE:
    case USBDEVFS_DISCONNECT_CLAIM:
      if (script_.claim_busy) umockdev_ioctl_client_complete(client, -1, EBUSY);
      else umockdev_ioctl_client_complete(client, 0, 0);
      return TRUE;
    case USBDEVFS_RELEASEINTERFACE:
    case USBDEVFS_CLEAR_HALT:
      umockdev_ioctl_client_complete(client, 0, 0);
      return TRUE;
    case USBDEVFS_SUBMITURB: {
      auto* urb = reinterpret_cast<usbdevfs_urb*>(data->data);
      UMockdevIoctlData* buffer = umockdev_ioctl_data_resolve(
          data, offsetof(usbdevfs_urb, buffer), static_cast<gsize>(urb->buffer_length), &error);
      if (buffer == nullptr) {
        g_clear_error(&error);
        umockdev_ioctl_client_complete(client, -1, EFAULT);
        return TRUE;
      }
      g_object_ref(data);  // kept until reaped
      if (urb->type == USBDEVFS_URB_TYPE_CONTROL) {
        handle_control(data, buffer);
        reapable_.push_back(data);
      } else if (urb->type == USBDEVFS_URB_TYPE_BULK && urb->endpoint == proto::bulk_in_endpoint) {
        ++bulk_outstanding_;
        if (bulk_outstanding_ > peak_bulk_outstanding_) peak_bulk_outstanding_ = bulk_outstanding_;
        if (running_ && next_chunk_ < script_.chunks.size()) {
          const auto& chunk = script_.chunks[next_chunk_++];
          const std::size_t n = std::min<std::size_t>(chunk.size(), static_cast<std::size_t>(urb->buffer_length));
          std::memcpy(buffer->data, chunk.data(), n);
          urb->actual_length = static_cast<int>(n);
          urb->status = 0;
          reapable_.push_back(data);
        } else {
          held_.push_back(data);
          if (running_ && script_.disconnect_after_chunks) disconnect_locked();
        }
      } else {
        urb->status = -EPIPE;
        reapable_.push_back(data);
      }
      umockdev_ioctl_client_complete(client, 0, 0);
      return TRUE;
    }
    default:
      umockdev_ioctl_client_complete(client, -1, ENOTTY);
      return TRUE;
  }
}

void MockFrontEnd::handle_control(UMockdevIoctlData* urb_data, UMockdevIoctlData* buffer) {
  auto* urb = reinterpret_cast<usbdevfs_urb*>(urb_data->data);
  const std::uint8_t* setup = buffer->data;
  ControlSeen seen{setup[0], setup[1], static_cast<std::uint16_t>(setup[2] | (setup[3] << 8)),
                   static_cast<std::uint16_t>(setup[4] | (setup[5] << 8)), {}};
  const int length = setup[6] | (setup[7] << 8);
  std::uint8_t* payload = buffer->data + 8;
  urb->status = 0;
  urb->actual_length = 0;
  if ((seen.request_type & 0x80) == 0) seen.data.assign(payload, payload + length);
  controls_.push_back(seen);
  if ((seen.request_type & 0x60) != 0x40 || seen.request == script_.refuse_request) {
    urb->status = -EPIPE;  // a stalled control request
    return;
  }
  switch (seen.request) {
    case proto::request_start: running_ = true; break;
    case proto::request_stop: running_ = false; break;
    case proto::request_set_sample_rate:
      if (length == 4) sample_rate_Hz_ = payload[0] | (payload[1] << 8) | (payload[2] << 16) | (static_cast<std::uint32_t>(payload[3]) << 24);
      break;
    case proto::request_set_channel_mask: channel_mask_ = seen.value; break;
    case proto::request_set_gain: break;
    case proto::request_get_info:
      if (length >= static_cast<int>(proto::info_size)) {
        proto::encode_info(script_.info, payload);
        urb->actual_length = static_cast<int>(proto::info_size);
      }
      break;
    case proto::request_get_status:
      if (length >= static_cast<int>(proto::status_size)) {
        proto::Status s;
        s.running = running_ ? 1 : 0;
        s.channel_mask = channel_mask_;
        s.sample_rate_Hz = sample_rate_Hz_;
        proto::encode_status(s, payload);
        urb->actual_length = static_cast<int>(proto::status_size);
      }
      break;
    default: urb->status = -EPIPE; break;
  }
}

WithoutFileCapabilities::WithoutFileCapabilities() {
  __user_cap_header_struct header{_LINUX_CAPABILITY_VERSION_3, 0};
  __user_cap_data_struct data[2]{};
  if (syscall(SYS_capget, &header, data) != 0) return;
  std::memcpy(saved_, data, sizeof data);
  data[0].effective &= ~((1u << CAP_DAC_OVERRIDE) | (1u << CAP_DAC_READ_SEARCH));
  changed_ = syscall(SYS_capset, &header, data) == 0;
}

WithoutFileCapabilities::~WithoutFileCapabilities() {
  if (!changed_) return;
  __user_cap_header_struct header{_LINUX_CAPABILITY_VERSION_3, 0};
  __user_cap_data_struct data[2]{};
  std::memcpy(data, saved_, sizeof data);
  syscall(SYS_capset, &header, data);
}

}  // namespace pvdf_test
