import { render, screen, waitFor } from '@testing-library/react';
import { afterEach, describe, expect, it, vi } from 'vitest';
import { StatusBar } from './StatusBar';

afterEach(() => vi.unstubAllGlobals());

function readyz(data: Record<string, unknown>) {
  const body = { status: 'ready', data: { mcp_servers: { navigation: 'connected' }, deployment: 'dev', ...data } };
  vi.stubGlobal(
    'fetch',
    vi.fn(async () => new Response(JSON.stringify(body), { status: 200 })),
  );
}

describe('status bar', () => {
  it('says which understanding is active for the planner and the chat', async () => {
    readyz({
      llm: 'rules',
      planner: 'rules',
      llm_understanding: 'rules + embedded matcher',
      planner_understanding: 'rules + embedded matcher',
      planner_state: 'ok',
    });
    render(<StatusBar />);
    const line = await screen.findByTestId('understanding');
    expect(line).toHaveTextContent('planner rules + embedded matcher · chat rules + embedded matcher · deployment dev');
  });

  it('marks a planner running on its fallback', async () => {
    readyz({
      llm: 'rules',
      planner: 'chain[anthropic,rules]',
      planner_understanding: 'rules + embedded matcher (fallback: anthropic failed)',
      planner_state: 'degraded',
    });
    render(<StatusBar />);
    await waitFor(() => expect(screen.getByText(/fallback: anthropic failed/)).toHaveClass('text-status-failed'));
  });

  it('falls back to the planner name for a brain that does not report its understanding', async () => {
    readyz({ llm: 'anthropic', planner: 'anthropic' });
    render(<StatusBar />);
    expect(await screen.findByTestId('understanding')).toHaveTextContent('planner anthropic · chat anthropic');
  });
});
