"""One module per `signcast` sub-command."""
