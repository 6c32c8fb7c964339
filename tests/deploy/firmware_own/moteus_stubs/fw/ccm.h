// encal test stub (not mjbots code): no core-coupled memory on the host.
#pragma once
#define MOTEUS_CCM_ATTRIBUTE
