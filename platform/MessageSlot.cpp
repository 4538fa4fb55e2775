#include <cstring>

#include "platform/Transport.hpp"

namespace areomap::platform {

void MessageSlot::store(void* context, const char* /*channel*/, const uint8_t* data, std::size_t size) {
  MessageSlot& slot = *static_cast<MessageSlot*>(context);
  ++slot.received;
  if (size > slot.capacity || slot.storage == nullptr) {
    ++slot.dropped;
    slot.size = 0;
    slot.status = Status::kCapacityExceeded;
    return;
  }
  if (size > 0) std::memcpy(slot.storage, data, size);
  slot.size = size;
  slot.status = Status::kOk;
}

}  // namespace areomap::platform
