#pragma once
#define ESP_LOGW(tag, fmt, ...) ((void)(tag))
