"""Device drivers of the flight code, one module per device, each a sans-I/O codec plus a thin
serial part (pyserial ``Serial`` or anything with the same calls, see :mod:`.base`):

* :mod:`.xbus` / :mod:`.mtdata` / :mod:`.xsens` - XSENS MTi (Xbus framing, MTData2 or legacy
  MTData payloads, the driver);
* :mod:`.buspirate_protocol`, :mod:`.buspirate_spi` + :mod:`.mcp3204` - the MCP3204 ADC behind a Bus Pirate in binary SPI;
* :mod:`.analog` - ADC codes to pressure, altitude and specific force;
* :mod:`.ppm_capture` / :mod:`.sbus` - RC input (timer-capture PPM records or SBUS);
* :mod:`.maestro` - Pololu Maestro Set Multiple Targets for the four ESCs;
* :mod:`.xbee` - XBee API-mode TX16 telemetry downlink.
"""
