/* encal test stub: nothing of the SSP driver is needed on the host. */
